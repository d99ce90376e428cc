"""A region of the face mesh (vto_core.products.FaceRegion: the lips, each eye's lid) in a photo: its polygons, its
mask, whether the photo shows it well enough to read (the square that frames it is vto_core.photo.framing.region_frame).
numpy only.

Coordinates: x, y in pixels from the top-left corner of the image; pixel (i, j) covers [i, i+1) x [j, j+1).
"""

from __future__ import annotations

import math

import numpy as np

from ..colour import srgb_to_lab
from ..products import FaceRegion
from .face_reader import polygon_mask, roll_of, tight_box

# An open eye shows its white beside its iris and lashes. Two measures of the pixels inside the opening, on the portraits
# of benchmarks/photos and the held-out faces (results/eyeshadow_photos.md, "found"), open eyes against both eyes
# covered by sunglasses (a dark lens with a highlight) or by a hand (the face's own cheek moved over them):
# - the L* spread, 95th minus 5th percentile: open 25-87; sunglasses 2-9;
# - the chroma of its white over the median chroma of the cheek under it: the lower quartile of the chroma of the
#   opening's brightest third (an eye's white is grey beside skin, and a bright shade or skin that a mesh a little off
#   takes into the opening raises the upper part only). Chosen on data/faces' 98 training faces: open eyes over 0.85 in
#   2 of 196 lids upright, 4 at 30 degrees, 6 at -45; both eyes under their own cheek refused on 58 of 98 faces. The
#   median of the brightest fifth, used before with a limit of 0.9: 3, 8 and 12 lids, 56 faces.
# An opening of fewer pixels than MIN_OPENING_PIXELS (a closed eye) shows its lid whole and is not judged.
MIN_OPENING_CONTRAST = 18.0
MAX_WHITE_CHROMA = 0.85
MIN_OPENING_PIXELS = 12


def region_polygons(landmarks: np.ndarray, region: FaceRegion) -> list[np.ndarray]:
    """The region's loops in image pixels: [(K, 2) float32, ...] from the face mesh's landmarks (468, 2), outer first.
    """
    landmarks = np.asarray(landmarks)
    return [landmarks[list(loop)] for loop in region.loops]


def bounds_in(polygon: np.ndarray, height: int, width: int) -> tuple[int, int, int, int]:
    """x, y, w, h of the whole pixels that the (K, 2) polygon's bounds cover in a height x width image (w or h 0
    where they cover none)."""
    x0, y0 = (max(0, int(math.floor(v))) for v in polygon.min(axis=0))
    x1, y1 = min(width, int(math.ceil(polygon[:, 0].max()))), min(height, int(math.ceil(polygon[:, 1].max())))
    return x0, y0, max(0, x1 - x0), max(0, y1 - y0)


def region_mask(polygons: list[np.ndarray], height: int, width: int) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """(height, width) float32 0/1 inside the first polygon (K, 2) and outside the others (the holes), and its tight
    box (x, y, w, h; (0, 0, 0, 0) when empty). Only the first polygon's box is rasterised."""
    outer = np.asarray(polygons[0])
    mask = np.zeros((height, width), np.float32)
    x0, y0, w, h = bounds_in(outer, height, width)
    if not (w and h):
        return mask, (0, 0, 0, 0)
    inside = polygon_mask(outer, x0, y0, w, h)
    for hole in polygons[1:]:
        inside &= ~polygon_mask(np.asarray(hole), x0, y0, w, h)
    mask[y0:y0 + h, x0:x0 + w] = inside
    x, y, w, h = tight_box(inside)
    return mask, (x + x0, y + y0, w, h) if w else (0, 0, 0, 0)


def region_width(landmarks: np.ndarray, region: FaceRegion) -> float:
    """px across the region's outer loop along the face's own axis (the same at any roll), from (468, 2) landmarks."""
    roll = roll_of(np.asarray(landmarks))
    outer = np.asarray(landmarks, np.float64)[list(region.loops[0])]
    return float(np.ptp(outer @ np.array([math.cos(roll), math.sin(roll)])))


def inside_lab(image: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """(N, 3) float64 CIELAB of the pixels of (H, W, 3) display sRGB whose centres lie inside polygon (K, 2); reads its
    box only."""
    height, width = image.shape[:2]
    x0, y0 = (max(0, int(math.floor(v))) for v in polygon.min(axis=0))
    x1, y1 = min(width, int(math.ceil(polygon[:, 0].max()))), min(height, int(math.ceil(polygon[:, 1].max())))
    if x1 <= x0 or y1 <= y0:
        return np.zeros((0, 3))
    inside = polygon_mask(polygon, x0, y0, x1 - x0, y1 - y0)
    return srgb_to_lab(np.clip(np.asarray(image[y0:y1, x0:x1], np.float32)[inside], 0.0, 1.0)).astype(np.float64)


def opening_contrast(image: np.ndarray, landmarks: np.ndarray, region: FaceRegion) -> float | None:
    """L* between the 5th and 95th percentile of the pixels of (H, W, 3) display sRGB inside the region's opening loop;
    None where it covers fewer than MIN_OPENING_PIXELS (a closed eye) or the region has no opening."""
    if not region.opening:
        return None
    lab = inside_lab(image, np.asarray(landmarks, np.float64)[list(region.opening)])
    if len(lab) < MIN_OPENING_PIXELS:
        return None
    low, high = np.percentile(lab[:, 0], (5, 95))
    return float(high - low)


def white_chroma(image: np.ndarray, landmarks: np.ndarray, region: FaceRegion) -> float | None:
    """The lower quartile of the chroma of the brightest third of the opening's pixels over the median chroma of the
    bare skin's outer loop's (near 0.3 where an eye's white shows, near 1 where skin covers it); None where either has
    too few pixels or the region has no bare skin."""
    if not (region.opening and region.bare_skin is not None):
        return None
    points = np.asarray(landmarks, np.float64)
    opening = inside_lab(image, points[list(region.opening)])
    skin = inside_lab(image, points[list(region.bare_skin.loops[0])])
    if len(opening) < MIN_OPENING_PIXELS or len(skin) < MIN_OPENING_PIXELS:
        return None
    bright = opening[opening[:, 0] >= np.percentile(opening[:, 0], 67)]
    return float(np.percentile(np.hypot(bright[:, 1], bright[:, 2]), 25)
                 / max(float(np.median(np.hypot(skin[:, 1], skin[:, 2]))), 1.0))


def unseen_reason(image: np.ndarray, landmarks: np.ndarray, region: FaceRegion) -> str:
    """'' where the photo (H, W, 3) shows the region well enough to read; else why not, as the end of a sentence: 'too
    small (12 px across; at least 16)' or 'hidden (...)'."""
    across = region_width(landmarks, region)
    if across < region.min_width:
        return f"too small ({across:.0f} px across; at least {region.min_width:.0f})"
    contrast = opening_contrast(image, landmarks, region)
    if contrast is not None and contrast < MIN_OPENING_CONTRAST:
        return f"hidden (the eye does not show between the lids: sunglasses or a hand?; L* spread {contrast:.0f})"
    white = white_chroma(image, landmarks, region)
    if white is not None and white > MAX_WHITE_CHROMA:
        return f"hidden (no eye's white shows between the lids: a hand?; its chroma {white:.2f} of the cheek's)"
    return ""
