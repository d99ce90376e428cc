"""What the extension ships beside its code: the models (with their model cards) and data files, and the photo reader
built on the shipped face and person models."""

from __future__ import annotations

import functools
from pathlib import Path

MODELS = Path(__file__).parent / "models"
DATA = Path(__file__).parent / "data"
FACE_DETECTOR, FACE_LANDMARKS = "face_detector.onnx", "face_landmarks.onnx"  # models/face_locator.md
PERSON_SEGMENTER = "person_segmenter.onnx"  # models/person_segmenter.md


@functools.lru_cache(maxsize=1)
def photo_reader():
    """The vto_core.photo.photo_reader.PhotoReader of the shipped face and person models (one a process: it keeps the
    last photo's face and hair)."""
    from vto_core.photo.photo_reader import PhotoReader

    return PhotoReader(MODELS / FACE_DETECTOR, MODELS / FACE_LANDMARKS, MODELS / PERSON_SEGMENTER)
