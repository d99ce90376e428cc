"""A region of the face mesh (vto_core.products.FaceRegion: the lips; the eyelids next) in a photo: its polygons, its
mask (the square that frames it is vto_core.photo.framing.region_frame). numpy only.

Coordinates: x, y in pixels from the top-left corner of the image; pixel (i, j) covers [i, i+1) x [j, j+1).
"""

from __future__ import annotations

import math

import numpy as np

from ..products import FaceRegion
from .face_reader import polygon_mask, tight_box


def region_polygons(landmarks: np.ndarray, region: FaceRegion) -> list[np.ndarray]:
    """The region's loops in image pixels: [(K, 2) float32, ...] from the face mesh's landmarks (468, 2), outer first.
    """
    landmarks = np.asarray(landmarks)
    return [landmarks[list(loop)] for loop in region.loops]


def region_mask(polygons: list[np.ndarray], height: int, width: int) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """(height, width) float32 0/1 inside the first polygon (K, 2) and outside the others (the holes), and its tight
    box (x, y, w, h; (0, 0, 0, 0) when empty). Only the first polygon's box is rasterised."""
    outer = np.asarray(polygons[0])
    mask = np.zeros((height, width), np.float32)
    x0, y0 = (max(0, int(math.floor(v))) for v in outer.min(axis=0))
    x1, y1 = min(width, int(math.ceil(outer[:, 0].max()))), min(height, int(math.ceil(outer[:, 1].max())))
    if x1 <= x0 or y1 <= y0:
        return mask, (0, 0, 0, 0)
    inside = polygon_mask(outer, x0, y0, x1 - x0, y1 - y0)
    for hole in polygons[1:]:
        inside &= ~polygon_mask(np.asarray(hole), x0, y0, x1 - x0, y1 - y0)
    mask[y0:y1, x0:x1] = inside
    x, y, w, h = tight_box(inside)
    return mask, (x + x0, y + y0, w, h) if w else (0, 0, 0, 0)
