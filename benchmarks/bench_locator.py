"""The lips locator (vto_core.photo.lips_locator): milliseconds per locate() at several image sizes, and how well it
finds the lips of the real-photo set against hand-drawn boxes.

Speed: scikit-image's astronaut upscaled (PIL bicubic) to squares of 0.26, 1, 2 and 12 megapixels, float32 in [0, 1],
the shipped face models with one onnxruntime thread (as inside Blender); the median and the best of --repeats calls
after one warm-up. Also the two paths that do more work: a picture without a face (the tiled second detector pass,
then the close-up test) and a mouth close-up. Accuracy: benchmarks/photos (when present) and the two package photos,
the IoU of the found lips box with the hand-drawn `lips_box`. Writes benchmarks/results/locator.md.

    python -m benchmarks.bench_locator [--repeats 20]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from benchmarks.common import box_iou, table, write_section

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "blender_addon" / "models"
PHOTOS = Path(__file__).parent / "photos"


def upscaled(image: np.ndarray, side: int) -> np.ndarray:
    """(H, W, 3) uint8 -> (side, side, 3) float32 in [0, 1], PIL bicubic."""
    from PIL import Image

    return np.asarray(Image.fromarray(image).resize((side, side), Image.BICUBIC), np.float32) / 255


def timings(call, repeats: int) -> tuple[float, float]:
    """Median and best milliseconds of `repeats` calls after one warm-up."""
    call()
    spent = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        spent.append(time.perf_counter() - start)
    return 1000 * float(np.median(spent)), 1000 * float(np.min(spent))


def speed(repeats: int) -> str:
    """The speed table as markdown."""
    from skimage import data

    from vto_core.errors import VtoError
    from vto_core.photo.face_reader import FaceReader
    from vto_core.photo.lips_locator import LipsLocator

    locator = LipsLocator(FaceReader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx", threads=1))
    astronaut = data.astronaut()

    def quietly(image):
        try:
            return locator.locate(image).how
        except VtoError:
            return "no lips found"

    cases = [(f"astronaut {side}x{side}", upscaled(astronaut, side)) for side in (512, 1024, 1448, 3464)]
    cases += [("rocket 1024x1024 (no face)", upscaled(data.rocket(), 1024)),
              ("astronaut's mouth 56x56 (close-up)", astronaut[117:173, 196:252].astype(np.float32) / 255)]
    rows = []
    for name, image in cases:
        median, best = timings(lambda image=image: quietly(image), repeats)
        megapixels = image.shape[0] * image.shape[1] / 1e6
        rows.append([name, f"{megapixels:.2f}", quietly(image), f"{median:.1f}", f"{best:.1f}"])
    return ("## Milliseconds per locate()\n\n"
            f"Shipped face models, one onnxruntime thread, median and best of {repeats} calls after a warm-up. A face "
            "costs one detector pass (128 px) and two mesh passes (192 px, the second on the region the first one's "
            "landmarks give). A picture without a face costs the whole-image pass, 13 more on overlapping squares "
            "(2 x 2, then 3 x 3), then the close-up test.\n\n"
            + table(["image", "megapixels", "result", "median ms", "best ms"], rows)
            + "\n\nReproduce: `python -m benchmarks.bench_locator`.")


def photo_records() -> list[tuple[str, np.ndarray, list | None, int, bool]]:
    """(name, image (H, W, 3) uint8, hand lips box or None, faces, held out) of the real-photo set."""
    import matplotlib.cbook
    from PIL import Image
    from skimage import data

    records = json.loads((PHOTOS / "photos.json").read_text()) if (PHOTOS / "photos.json").is_file() else []
    found = []
    for record in records:
        name = record["file"]
        if name == "package:skimage.data.astronaut":
            image = data.astronaut()
        elif name.startswith("package:matplotlib"):
            with matplotlib.cbook.get_sample_data("grace_hopper.jpg") as handle:
                image = np.asarray(Image.open(handle).convert("RGB"))
        else:
            with Image.open(PHOTOS / name) as picture:
                image = np.asarray(picture.convert("RGB"))
        found.append((name, image, record["lips_box"], record["faces"], bool(record.get("held_out"))))
    return found


def accuracy() -> str:
    """The accuracy table on the real-photo set as markdown ('' when the set is missing)."""
    from vto_core.errors import VtoError
    from vto_core.photo.face_reader import FaceReader
    from vto_core.photo.lips_locator import LipsLocator

    records = photo_records()
    if not records:
        return ""
    locator = LipsLocator(FaceReader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx", threads=1))
    rows, ious, held_out = [], [], []
    for name, image, hand_box, faces, held in records:
        name += " (held out)" if held else ""
        try:
            found = locator.locate(image.astype(np.float32) / 255)
        except VtoError as error:
            rows.append([name, f"{image.shape[1]}x{image.shape[0]}", faces, str(error).split(":")[0], "", "", ""])
            continue
        overlap = box_iou(found.box, hand_box) if hand_box else float("nan")
        ious += [overlap] if hand_box else []
        held_out += [overlap] if hand_box and held else []
        rows.append([name, f"{image.shape[1]}x{image.shape[0]}", faces, f"{found.how}, {found.faces} face(s)",
                     list(found.box), hand_box, f"{overlap:.2f}"])
    return ("## Lips found on the real-photo set\n\n"
            f"benchmarks/photos (public-domain NASA portraits; see its README) and the two package photos: the box "
            f"of the found lips mask against the hand-drawn `lips_box` (x, y, w, h). Median IoU "
            f"{np.median(ious):.2f}, lowest {np.min(ious):.2f} (over {len(ious)} photos with lips)"
            + (f"; on the {len(held_out)} held out (added after the locator was built, measured once): median "
               f"{np.median(held_out):.2f}, lowest {np.min(held_out):.2f}" if held_out else "") + ".\n\n"
            + table(["photo", "size", "faces (hand count)", "result", "found box", "hand box", "IoU"], rows)
            + "\n\nReproduce: `python -m benchmarks.bench_locator`.")


def main(argv: list[str] | None = None) -> None:
    """Measure and write benchmarks/results/locator.md."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args(argv)
    write_section("locator", "locator-speed", speed(args.repeats))
    text = accuracy()
    if text:
        write_section("locator", "locator-accuracy", text)


if __name__ == "__main__":
    main()
