"""The shipped encoders on a real photograph: scikit-image's astronaut portrait, cropped to the lips and to the hair.

    .venv/bin/python scripts/try_real_photos.py [--out out/real]

Writes OUT/sheet.png (per renderer: the photo crop | the estimate rendered on the default scene, at 128 px) and
OUT/estimates.json. What the estimates look like is reported in the model cards; this script is how to see it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import skimage.data

from blender_addon.commands import render
from vto_core.imageio import resize, write_image
from vto_core.inference import EncoderSession

MODELS = Path(__file__).resolve().parent.parent / "blender_addon" / "models"
# (row slice, column slice) of the 512 x 512 astronaut portrait: the mouth, and a patch of hair only (with the face
# and the background in the crop the hair encoder reads skin: the default hair scene never shows a face).
CROPS = {"lipstick": (slice(117, 173), slice(196, 252)), "hair": (slice(20, 90), slice(150, 230))}
SOURCES = {"lipstick": 1, "hair": 1}
SHOW = 128


def main() -> None:
    """Estimate each renderer's parameters from its crop and render them beside it."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="out/real")
    out = Path(parser.parse_args().out)
    photo = skimage.data.astronaut().astype(np.float32) / 255
    rows, estimates = [], {}
    for renderer, (rows_slice, cols_slice) in CROPS.items():
        model = MODELS / f"{renderer}_encoder.onnx"
        if not model.exists():
            continue
        crop = photo[rows_slice, cols_slice]
        values = EncoderSession(str(model)).predict(crop)[0]
        estimates[renderer] = {k: round(float(v), 3) for k, v in values.items()}
        rendered = render(renderer, values, SOURCES[renderer], SHOW, 32)
        rows.append(np.concatenate([resize(crop, SHOW, SHOW), rendered], axis=1))
    out.mkdir(parents=True, exist_ok=True)
    write_image(out / "sheet.png", np.concatenate(rows, axis=0))
    (out / "estimates.json").write_text(json.dumps(estimates, indent=1))
    print(json.dumps({"sheet": str(out / "sheet.png"), **estimates}))


if __name__ == "__main__":
    main()
