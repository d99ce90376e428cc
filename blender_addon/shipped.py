"""What the extension ships beside its code: the models (with their model cards) and data files, and the face
reader built on the shipped face models."""

from __future__ import annotations

from pathlib import Path

MODELS = Path(__file__).parent / "models"
DATA = Path(__file__).parent / "data"
FACE_DETECTOR, FACE_LANDMARKS = "face_detector.onnx", "face_landmarks.onnx"  # models/face_locator.md
PERSON_SEGMENTER = "person_segmenter.onnx"  # models/person_segmenter.md


def read_face(image):
    """The largest face of (H, W, 3) (vto_core.photo.face_reader.FaceRead) with the shipped face models, or None."""
    from vto_core.photo.face_reader import cached_reader

    return cached_reader(MODELS / FACE_DETECTOR, MODELS / FACE_LANDMARKS).read(image)
