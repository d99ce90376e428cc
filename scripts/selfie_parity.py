"""Check person_segmenter.onnx against MediaPipe's own selfie segmentation graph on real photos.

Run in a venv with the mediapipe wheel (never the project's):
    python3 -m venv /tmp/mpv && /tmp/mpv/bin/pip install /tmp/wheels/mediapipe-0.10.21-*.whl \\
        onnxruntime==1.31.1 scikit-image
    /tmp/mpv/bin/python scripts/selfie_parity.py [--onnx blender_addon/models/person_segmenter.onnx]
MediaPipe's graph (SelfieSegmentation, model_selection=0) stretches the picture to 256 x 256 (no letterbox), runs the
tflite with its custom op, and resizes the probabilities back. Here the picture is stretched with scikit-image's
bilinear resize, the ONNX model run on onnxruntime, and the result resized back the same way. Printed per photo: the
IoU of the two person masks (probability > 0.5) and the mean |difference| of the probabilities.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def photos() -> dict[str, np.ndarray]:
    """The benchmark's photos (H, W, 3) uint8, the packaged astronaut among them."""
    from skimage import data, io

    records = json.loads((ROOT / "benchmarks" / "photos" / "photos.json").read_text())
    images = {"astronaut": data.astronaut()}
    for record in records:
        if not record["file"].startswith("package:"):
            images[record["file"]] = io.imread(ROOT / "benchmarks" / "photos" / record["file"])[..., :3]
    return images


def onnx_mask(session, image: np.ndarray) -> np.ndarray:
    """(H, W) person probability from the ONNX model, the picture stretched to 256 x 256 and back."""
    from skimage.transform import resize

    small = resize(image.astype(np.float32) / 255, (256, 256), order=1, anti_aliasing=False).astype(np.float32)
    (probability,) = session.run(None, {session.get_inputs()[0].name: small.transpose(2, 0, 1)[None]})
    return resize(probability[0, 0], image.shape[:2], order=1)


def main() -> None:
    """Print the parity figures."""
    import mediapipe as mp
    import onnxruntime

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--onnx", type=Path, default=ROOT / "blender_addon" / "models" / "person_segmenter.onnx")
    args = parser.parse_args()
    session = onnxruntime.InferenceSession(str(args.onnx), providers=["CPUExecutionProvider"])
    ious = []
    with mp.solutions.selfie_segmentation.SelfieSegmentation(model_selection=0) as segmenter:
        for name, image in photos().items():
            theirs = segmenter.process(np.ascontiguousarray(image)).segmentation_mask
            ours = onnx_mask(session, image)
            union = ((theirs > 0.5) | (ours > 0.5)).sum()
            iou = ((theirs > 0.5) & (ours > 0.5)).sum() / max(union, 1)
            ious.append(iou)
            print(f"{name:36s} IoU {iou:.4f}  mean |diff| {np.abs(theirs - ours).mean():.4f}  "
                  f"person {float((theirs > 0.5).mean()):.3f}")
    print(f"median IoU {np.median(ious):.4f}, lowest {min(ious):.4f} over {len(ious)} photos")


if __name__ == "__main__":
    main()
