"""What the extension ships beside its code: the models (with their model cards) and data files, and the face and
lips readers built on the shipped face models."""

from __future__ import annotations

from pathlib import Path

MODELS = Path(__file__).parent / "models"
DATA = Path(__file__).parent / "data"
FACE_DETECTOR, FACE_LANDMARKS = "face_detector.onnx", "face_landmarks.onnx"  # models/face_locator.md
PERSON_SEGMENTER = "person_segmenter.onnx"  # models/person_segmenter.md


def locate_lips(image, face=None):
    """vto_core.photo.lips_locator.LipsFound for (H, W, 3) with the shipped face models (loaded once), from `face`
    where it was read already; VtoError 'no lips found ...' where there are none."""
    from vto_core.photo.lips_locator import cached_locator

    return cached_locator(MODELS / FACE_DETECTOR, MODELS / FACE_LANDMARKS).locate(image, face)


def read_face(image):
    """The largest face of (H, W, 3) (vto_core.photo.face_reader.FaceRead) with the shipped face models, or None."""
    from vto_core.photo.face_reader import cached_reader

    return cached_reader(MODELS / FACE_DETECTOR, MODELS / FACE_LANDMARKS).read(image)
