"""Bring the Face Research Lab London Set into data/faces/london/: each head cropped (a square about the face the face
mesh finds), at most 800 px a side, JPEG quality 92, no metadata; faces.json records the source, licence, crop and
split of every file. The 39 evaluation identities (issue "Dark lipsticks read dark") are never trained on.

    usage: python scripts/import_london_set.py REPO   (a checkout of github:debruine/webmorphR.stim)
"""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "faces" / "london"
REPOSITORY = "debruine/webmorphR.stim"
LICENCE = ("CC BY 4.0: DeBruine, L., & Jones, B. (2017). Face Research Lab London Set (Version 5). figshare. "
           "https://doi.org/10.6084/m9.figshare.5047666.v5")
ORIGIN = ("Face Research Lab London Set: 102 adults photographed in one studio in London, April 2012, under one light, "
          "1350 x 1350 px; consent to use 'in their original or altered forms and to illustrate research'")
EXPRESSIONS = {"neutral": ("inst/neutral_front", "03"), "smiling": ("inst/smiling_front", "08")}
# Evaluation only, never trained on: 10 black, 9 east Asian, 10 west Asian and 10 white identities.
EVALUATION = {
    "black": "025 042 043 044 061 062 082 099 126 129",
    "east_asian": "005 024 030 034 045 067 087 119 127",
    "west_asian": "006 008 037 038 064 066 070 115 135 142",
    "white": "001 002 003 007 009 010 011 013 014 016",
}
MAX_SIDE, QUALITY = 800, 92
HEAD_SCALE = 2.2  # the crop's side, in face-box sides: the whole head and some shoulder, as a portrait frames it
HEAD_RAISE = 0.15  # the crop's centre above the face box's, in face-box sides: the hair above the forehead


def git(repo: Path, *args: str) -> bytes:
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True).stdout


def head_crop(rgb: np.ndarray) -> tuple[int, int, int]:
    """(x, y, side) of the square about the face the face mesh finds in (H, W, 3), inside the image."""
    from vto_core.photo.face_reader import cached_reader

    models = ROOT / "blender_addon" / "models"
    face = cached_reader(models / "face_detector.onnx", models / "face_landmarks.onnx").read(rgb)
    if face is None:
        raise SystemExit("no face found: the London Set's photos are all frontal faces")
    x, y, w, h = face.box
    side = min(int(round(HEAD_SCALE * max(w, h))), *rgb.shape[:2])
    cx, cy = x + w / 2, y + h / 2 - HEAD_RAISE * max(w, h)
    x0 = min(max(int(round(cx - side / 2)), 0), rgb.shape[1] - side)
    y0 = min(max(int(round(cy - side / 2)), 0), rgb.shape[0] - side)
    return x0, y0, side


def main(repo: Path) -> None:
    commit = git(repo, "rev-parse", "HEAD").decode().strip()
    info = {row["face_id"]: row for row in csv.DictReader(io.StringIO(git(repo, "show", "HEAD:data-raw/london_info.csv")
                                                                      .decode()))}
    evaluation = {face: group for group, faces in EVALUATION.items() for face in faces.split()}
    OUT.mkdir(parents=True, exist_ok=True)
    records = []
    for face_id, row in sorted(info.items()):
        for expression, (folder, suffix) in EXPRESSIONS.items():
            path = f"{folder}/{face_id}_{suffix}.jpg"
            data = git(repo, "show", f"HEAD:{path}")
            image = Image.open(io.BytesIO(data)).convert("RGB")
            x, y, side = head_crop(np.asarray(image, np.float32) / 255)
            head = image.crop((x, y, x + side, y + side))
            if side > MAX_SIDE:
                head = head.resize((MAX_SIDE, MAX_SIDE), Image.LANCZOS)
            name = f"london_{face_id}_{expression}.jpg"
            head.save(OUT / name, quality=QUALITY)  # Pillow writes no metadata unless given it
            records.append({
                "file": f"data/faces/london/{name}",
                "subject": f"London Set face {face_id}, {expression}",
                "source": {"repository": REPOSITORY, "path": path, "commit": commit,
                           "blob": git(repo, "rev-parse", f"HEAD:{path}").decode().strip(), "url": None,
                           "origin": ORIGIN},
                "licence": LICENCE,
                "processing": (f"cropped to the square x={x}, y={y}, side={side} px of the {image.width}x{image.height} "
                               f"original (the head about the face the face mesh finds), downscaled (Lanczos) to at "
                               f"most {MAX_SIDE} px, JPEG quality {QUALITY}, no metadata"),
                "crop": [x, y, side, side],
                "size": list(head.size),
                "original_size": [image.width, image.height],
                "expression": expression,
                "age": int(row["face_age"]) if row["face_age"].isdigit() else None, "gender": row["face_gender"], "ethnicity": row["face_eth"],
                "lips_visible": True, "lipstick": "none", "lipstick_confidence": "medium",
                "split": "evaluation" if face_id in evaluation else "train",
                "group": evaluation.get(face_id, ""),
            })
            print(name, records[-1]["split"], file=sys.stderr)
    (OUT / "faces.json").write_text(json.dumps(records, indent=1) + "\n", encoding="utf-8")
    print(OUT / "faces.json")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    main(Path(sys.argv[1]))
