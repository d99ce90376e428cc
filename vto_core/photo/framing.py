"""How a photo's face region (the lips, a lid) is framed for what reads or draws it: the square its default scene
frames it in, on the pixel grid, or turned with a tilted face. numpy only, so this runs inside Blender's extension.

Shapes: images (H, W, C); boxes (x, y, w, h) in pixels from the top-left corner; a view is a (2, 3) affine map from
the pixel coordinates of an n x n frame to the photo's (pixel centres at +0.5).
"""

from __future__ import annotations

import math

import numpy as np

from ..products import FaceRegion
from .face_reader import apply_matrix, roll_of, square_matrix, warp
from .photo_light import neutral_photo

MIN_SIZE = 8  # pixels: the smallest side of a reference (or a crop of one) that an estimate is made from
# A face rolled more than this is framed turned upright (face regions and hair) before the encoder reads it; below it
# the frame stays on the pixel grid (no resampling). The 18 portraits' own rolls are -9 to 3 degrees, 14 of them
# within 5.
ROLL_TOLERANCE = math.radians(5)


def cut(image: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    """The part `box` of `image`, contiguous."""
    x, y, w, h = box
    return np.ascontiguousarray(image[y:y + h, x:x + w])


def cut_read(whole: np.ndarray, box: tuple[int, int, int, int], light) -> np.ndarray:
    """The part `box` of `whole` (H, W, 3), with the photo's `light` taken out (None: as it is); a new array either
    way. A light read from the skin is taken out of the part where it lies (no contiguous copy first)."""
    if light is None:
        return cut(whole, box)
    x, y, w, h = box
    part = whole[y:y + h, x:x + w] if light.read_from == "skin" else cut(whole, box)  # relit writes a new array
    return neutral_photo(part, light)


def region_frame(mask: np.ndarray, width_share: float) -> tuple[int, int, int, int]:
    """(x, y, w, h) of the square that frames a region's mask (H, W) as the default scene frames the region: centred
    on the mask's box, whose width is `width_share` of the side (at least the box's height and MIN_SIZE); shrunk to the
    image's shorter side and moved inside the image where it would not fit."""
    rows, cols = np.flatnonzero(np.any(mask, axis=1)), np.flatnonzero(np.any(mask, axis=0))  # its box's rows, columns
    height, width = mask.shape
    side = max(math.ceil((cols.max() + 1 - cols.min()) / width_share), rows.max() + 1 - rows.min(), MIN_SIZE)
    side = min(side, height, width)
    centre_y, centre_x = (rows.min() + rows.max() + 1) / 2, (cols.min() + cols.max() + 1) / 2
    y = min(max(int(round(centre_y - side / 2)), 0), height - side)
    x = min(max(int(round(centre_x - side / 2)), 0), width - side)
    return x, y, side, side


def face_roll(landmarks) -> float:
    """The roll (radians, clockwise) a face is framed with: its roll where it passes ROLL_TOLERANCE, else 0."""
    roll = 0.0 if landmarks is None else roll_of(np.asarray(landmarks))
    return roll if abs(roll) > ROLL_TOLERANCE else 0.0


def turned_square(outer: np.ndarray, angle: float, width_share: float) -> tuple[np.ndarray, float]:
    """region_frame for a region turned by `angle` rad: its outer loop (K, 2) measured along the face's own axes ->
    (centre (2,), side px) of the square that frames it as the default scene frames it."""
    across, down = np.array([math.cos(angle), math.sin(angle)]), np.array([-math.sin(angle), math.cos(angle)])
    along, below = np.asarray(outer, np.float64) @ across, np.asarray(outer, np.float64) @ down
    side = max(math.ceil(np.ptp(along) / width_share), float(np.ptp(below)), MIN_SIZE)
    centre = across * (along.min() + along.max()) / 2 + down * (below.min() + below.max()) / 2
    return centre, float(side)


def square_view(centre: np.ndarray, side: float, angle: float) -> tuple[np.ndarray, int]:
    """The view of the square of `side` px centred on `centre` (x, y), turned by `angle` rad clockwise, at the
    photo's own scale: (view (2, 3), n)."""
    size = max(MIN_SIZE, int(round(side)))
    return square_matrix(np.asarray(centre, np.float64), side, angle, size), size


def region_view(found, region: FaceRegion) -> tuple[np.ndarray, int, float]:
    """The frame Match reads a found face `region` (vto_core.photo.lips_locator.RegionFound) through: (the view (2, 3)
    from an n x n frame to the photo, n, the turn in rad). On the pixel grid (region_frame of the mask, n its side)
    unless the face is rolled past ROLL_TOLERANCE: then turned with it (turned_square)."""
    turn = face_roll(found.landmarks) if found.how == "face" else 0.0
    if turn:
        return *square_view(*turned_square(found.outer, turn, region.frame_share), turn), turn
    x, y, side, _ = region_frame(found.mask, region.frame_share)
    return np.array([[1.0, 0.0, x], [0.0, 1.0, y]]), side, 0.0


def view_box(view: np.ndarray, size: int, shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """The pixel box (x, y, w, h) of an image of `shape` (H, W) that a view's size x size frame covers (clipped)."""
    corners = apply_matrix(view, np.array([[0, 0], [size, 0], [0, size], [size, size]], np.float64))
    height, width = shape
    x0, y0 = (max(0, int(math.floor(v + 1e-9))) for v in corners.min(axis=0))
    x1 = min(width, int(math.ceil(corners[:, 0].max() - 1e-9)))
    y1 = min(height, int(math.ceil(corners[:, 1].max() - 1e-9)))
    return x0, y0, max(0, x1 - x0), max(0, y1 - y0)


def view_cut(image: np.ndarray, view: np.ndarray, size: int, light=None) -> np.ndarray:
    """The size x size frame a view (2, 3) sees of (H, W, C) or (H, W): (size, size, C) float32, black outside the
    image; exact pixels where the view is a whole-pixel shift at scale 1. light: taken out of the colour (None: as
    it is)."""
    image = image[..., None] if image.ndim == 2 else image
    box = view_box(view, size, image.shape[:2])
    grown = (max(0, box[0] - 1), max(0, box[1] - 1))  # a pixel more each way for the bilinear step
    box = (grown[0], grown[1], min(image.shape[1], box[0] + box[2] + 1) - grown[0],
           min(image.shape[0], box[1] + box[3] + 1) - grown[1])
    part = cut(image, box) if light is None else cut_read(image, box, light)
    shifted = view.copy()
    shifted[:, 2] -= box[:2]
    return warp(part, shifted, size).transpose(1, 2, 0)
