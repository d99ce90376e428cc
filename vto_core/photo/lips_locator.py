"""Find the lips in a photo: the lip contours of the face mesh (vto_core.photo.face_reader), or, where no face shows, a
test of whether the picture is a close-up of lips. numpy only, so this runs inside Blender's extension.

Coordinates: x, y in pixels from the top-left corner of the image; pixel (i, j) covers [i, i+1) x [j, j+1), so its
centre is at (i + 0.5, j + 0.5).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..colour import srgb_to_lab
from ..errors import VtoError
from ..products import LIPS
from .face_reader import FaceRead, FaceReader, as_rgb, cached_reader, polygon_mask, reduce
from .face_regions import bounds_in, region_mask, region_polygons

LIP_OUTER, LIP_INNER = (list(loop) for loop in LIPS.loops)  # the face mesh's lip loops (vto_core.products.LIPS)
# The inner loop's points facing each other across the mouth: LIP_INNER[i] below, LIP_INNER[20 - i] above (0 and 10
# are the corners).
FACING = [(i, len(LIP_INNER) - i) for i in range(1, len(LIP_INNER) // 2)]
# A mouth is open where its inner contour holds teeth (a share of its pixels TEETH_LIFT L* above the lips' median) or
# a dark opening (CAVITY_DROP below). On the London Set and the NASA portraits (out of 111 faces), closed mouths hold
# no pixel so bright (0.00-0.01 of them) and smiles with teeth 0.05-0.67; a closed mouth whose inner contour is not
# closed left a band through the lips bare in the try-on (1-25 % of the lips on the skin-tone benchmark's faces).
TEETH_LIFT, TEETH_SHARE = 15.0, 0.03
CAVITY_DROP, CAVITY_SHARE = 25.0, 0.3

# The close-up test (see close_up_test): the picture reduced to CLOSE_UP_SIZE px on its longer side.
CLOSE_UP_SIZE = 48
MIN_CLOSE_UP_SIDE = 16
MIN_LENS_MATCH, LENS_MARGIN = 0.4, 0.1


@dataclass
class RegionFound:
    """A face region found in an image: the lips (LipsLocator.locate), an eye's lid or any other face-mesh region
    (vto_core.photo.photo_reader.PhotoReader.locate_region)."""

    mask: np.ndarray  # (H, W) float32 0/1: the region (its outer loop minus its hole: for the lips, no teeth, no mouth
    # opening; a closed mouth's inner contour is closed first, closed_mouth)
    box: tuple[int, int, int, int]  # x, y, w, h of the mask's tight box
    outer: np.ndarray  # (K, 2) float32 x, y of the region's outer loop in order (the outer lip contour); empty for a
    # close-up
    inner: np.ndarray  # (L, 2) float32 its hole's loop (the inner lip contour, closed on a closed mouth); empty where
    # it has none (an eye's lid) and for a close-up
    how: str  # "face" or "close-up"
    faces: int  # faces found (detections the face mesh confirms)
    score: float  # the mesh's face probability, or the close-up test's score
    note: str  # "" or one sentence for the user
    landmarks: np.ndarray | None = None  # (468, 2) float32 the whole face mesh in image pixels; None for a close-up
    face_box: tuple[float, float, float, float] | None = None  # x, y, w, h of the detector's box of the face used
    depth: np.ndarray | None = None  # (468,) float32 the face mesh's depth in image pixels, nearer lower


def blur(image: np.ndarray, passes: int = 2) -> np.ndarray:
    """(h, w, C) smoothed by `passes` separable [1, 2, 1] / 4 filters, edges repeated."""
    for _ in range(passes):
        padded = np.pad(image, ((1, 1), (0, 0), (0, 0)), mode="edge")
        image = (padded[:-2] + 2 * padded[1:-1] + padded[2:]) / 4
        padded = np.pad(image, ((0, 0), (1, 1), (0, 0)), mode="edge")
        image = (padded[:, :-2] + 2 * padded[:, 1:-1] + padded[:, 2:]) / 4
    return image


def close_up_test(image: np.ndarray) -> tuple[dict[str, float], tuple[float, float, float, float] | None]:
    """The close-up test on (H, W, 3): (each rule's margin, > 0 where it passes; the best lens (LENS_SHAPES) or None).

    On a copy reduced to CLOSE_UP_SIZE px and blurred, in CIELAB, with the surround the border band (15 % of the
    height at the top and bottom, 12 % of the width at the sides):
      size, aspect: the image is at least 16 px a side, and 1:2 to 6:1 (w:h);
      skin_hue, skin_chroma, skin_lightness: the surround's median colour is skin (hue 30-75 deg, chroma 12-55,
        L* 15-92);
      lens: a lips-shaped lens (a horizontal ellipse-like shape, 0.45-0.9 of the width, near the centre) matches both
        redness maps, a* above the surround's and hue turned towards red from the surround's, with a normalised
        cross-correlation of at least 0.4 each;
      redder: inside that lens a* is on average at least 2 above the surround's.
    Tuned on mouth crops of 12 public-domain portraits and 62 pictures that are not (face_locator.md).
    """
    height, width = image.shape[:2]
    rules = {"size": (min(height, width) - MIN_CLOSE_UP_SIDE) / MIN_CLOSE_UP_SIDE,
             "aspect": min(width / height - 0.5, 6.0 - width / height)}
    if min(rules.values()) <= 0:
        return rules, None
    factor = max(1, math.ceil(max(height, width) / CLOSE_UP_SIZE))
    lab = srgb_to_lab(blur(reduce(image, factor))).astype(np.float64)
    lightness, a_star, b_star = lab[..., 0], lab[..., 1], lab[..., 2]
    hue, chroma = np.degrees(np.arctan2(b_star, a_star)), np.hypot(a_star, b_star)
    rows, cols = lightness.shape
    surround = np.ones((rows, cols), bool)
    band_y, band_x = max(1, round(rows * 0.15)), max(1, round(cols * 0.12))
    surround[band_y:rows - band_y, band_x:cols - band_x] = False
    skin_hue, skin_chroma = np.median(hue[surround]), np.median(chroma[surround])
    skin_lightness, skin_a = np.median(lightness[surround]), np.median(a_star[surround])
    rules["skin_hue"] = min(skin_hue - 30.0, 75.0 - skin_hue) / 10
    rules["skin_chroma"] = min(skin_chroma - 12.0, 55.0 - skin_chroma) / 10
    rules["skin_lightness"] = min(skin_lightness - 15.0, 92.0 - skin_lightness) / 10
    redder_a = np.clip(a_star - skin_a, 0.0, None)
    redder_hue = np.where((chroma > 8) & (a_star > skin_a), np.clip(skin_hue - hue, 0.0, 40.0), 0.0)
    lenses, shapes = lens_templates(rows, cols)
    match = np.minimum(lenses @ standardised(redder_a), lenses @ standardised(redder_hue))
    best = int(np.argmax(match))
    inside = lenses[best].reshape(rows, cols) > 0
    rules["lens"] = (float(match[best]) - MIN_LENS_MATCH) / LENS_MARGIN
    rules["redder"] = (float(a_star[inside].mean() - skin_a) - 2.0) / 2.0 if inside.any() else -1.0
    return rules, shapes[best] if shapes else None


def standardised(values: np.ndarray) -> np.ndarray:
    """(h, w) -> (h * w,) zero mean, unit norm (all zeros for a constant map)."""
    flat = values.ravel() - values.mean()
    norm = np.sqrt(flat @ flat)
    return flat / norm if norm > 1e-9 else np.zeros_like(flat)


# (width share, height share of the width, centre x, centre y) of the lenses the close-up test tries: widths 0.45-0.9
# of the picture, heights 0.25-0.6 of the width, centres x 0.4-0.6, y 0.3-0.7.
LENS_SHAPES = tuple((w, h, x, y) for w in (0.45, 0.6, 0.75, 0.9) for h in (0.25, 0.4, 0.6) for x in (0.4, 0.5, 0.6)
                    for y in (0.3, 0.4, 0.5, 0.6, 0.7))
DEFAULT_LENS = (0.78, 0.4, 0.5, 0.5)  # where a crop framed as the default scene frames lips has them


def lens_mask(shape: tuple[float, float, float, float], rows: int, cols: int) -> np.ndarray:
    """The lens `shape` (LENS_SHAPES) on a rows x cols picture: (rows, cols) bool, |y - cy| < h/2 (1 - (2 (x - cx) /
    w)^2) in fractions of the picture."""
    lens_width, height_share, centre_x, centre_y = shape
    ys, xs = (np.arange(rows) + 0.5) / rows, (np.arange(cols) + 0.5) / cols
    lens_height = lens_width * cols * height_share / rows
    taper = np.clip(1 - ((xs - centre_x) / (lens_width / 2)) ** 2, 0.0, None)
    return np.abs(ys[:, None] - centre_y) < lens_height / 2 * taper[None, :]


def lens_outline(shape: tuple[float, float, float, float], height: int, width: int, points: int = 24) -> np.ndarray:
    """(2 points, 2) x, y pixel outline of the lens `shape` on a height x width picture, in order."""
    lens_width, height_share, centre_x, centre_y = shape
    x = centre_x + lens_width / 2 * np.cos(np.linspace(0, np.pi, points))
    taper = np.clip(1 - ((x - centre_x) / (lens_width / 2)) ** 2, 0, None)
    half = lens_width * width * height_share / height / 2 * taper
    upper = np.stack([x * width, (centre_y - half) * height], -1)
    lower = np.stack([x[::-1] * width, (centre_y + half[::-1]) * height], -1)
    return np.concatenate([upper, lower]).astype(np.float32)


@functools.lru_cache(maxsize=8)
def lens_templates(rows: int, cols: int) -> tuple[np.ndarray, tuple]:
    """(T, rows * cols) standardised lenses of LENS_SHAPES that fit a rows x cols map, and those shapes."""
    lenses, shapes = [], []
    for shape in LENS_SHAPES:
        lens = lens_mask(shape, rows, cols)
        if 0 < lens.sum() < lens.size:
            lenses.append(standardised(lens.astype(np.float64)))
            shapes.append(shape)
    return (np.array(lenses) if lenses else np.zeros((1, rows * cols))), tuple(shapes)


class LipsLocator:
    """The lips of one image from its face (vto_core.photo.face_reader), or, where no face shows, the close-up test."""

    def __init__(self, reader: FaceReader):
        self.reader = reader

    def locate(self, image: np.ndarray, face: FaceRead | None = None) -> RegionFound:
        """(H, W, 3) display sRGB (any size; NaN, inf and HDR values are cleaned; (H, W), (H, W, 4) and integer
        pixels taken too) -> the lips; VtoError 'no lips found ...' when there is neither a face nor a close-up of lips.

        face: the face already read in this image (FaceReader.read), so a caller that needs it too reads it once.
        Without a face, the close-up test decides."""
        image = as_rgb(image)
        height, width = image.shape[:2]
        face = self.reader.read(image) if face is None else face
        if face is not None:
            landmarks = face.landmarks
            outer, inner = region_polygons(landmarks, LIPS)
            if mouth_closed(image, outer, inner):
                landmarks = closed_mouth(landmarks)
                inner = landmarks[LIP_INNER]
            mask, box = region_mask([outer, inner], height, width)
            if not box[2]:
                raise VtoError("no lips found: the face is too small in this image (its lips cover no pixel); "
                               "crop the face or give a mask")
            return RegionFound(mask, box, outer, inner, "face", face.faces, face.score, face.note, landmarks, face.box,
                               face.depth)
        rules, lens = close_up_test(image)
        if min(rules.values()) <= 0:
            raise VtoError("no lips found: no face in the image, and it is not a close-up of lips; crop the lips or "
                           "give a mask")
        return close_up(image.shape[:2], lens, rules["lens"] * LENS_MARGIN + MIN_LENS_MATCH,
                        "no face found: the whole image is taken as a close-up of lips")


def mouth_closed(image: np.ndarray, outer: np.ndarray, inner: np.ndarray) -> bool:
    """Whether the mouth inside the inner lip contour (L, 2) is closed: no teeth and no dark opening there, against
    the lips between it and the outer contour (K, 2), in the (H, W, 3) display image. True where it holds no pixel."""
    x0, y0, w, h = box = bounds_in(outer, *image.shape[:2])
    if not (w and h):
        return True
    opening = polygon_mask(inner, *box)
    lips = polygon_mask(outer, *box) & ~opening
    if not opening.any() or not lips.any():
        return True
    lightness = srgb_to_lab(np.clip(image[y0:y0 + h, x0:x0 + w], 0.0, 1.0))[..., 0]
    middle = float(np.median(lightness[lips]))
    inside = lightness[opening]
    return bool(np.mean(inside > middle + TEETH_LIFT) < TEETH_SHARE and np.mean(inside < middle - CAVITY_DROP)
                < CAVITY_SHARE)


def closed_mouth(landmarks: np.ndarray) -> np.ndarray:
    """(468, 2) -> (468, 2): the inner lip contour's facing points moved together onto the line between the lips, so
    that the lips of a closed mouth are whole (the face mesh often leaves a gap between them)."""
    landmarks = np.array(landmarks, np.float32)
    for below, above in FACING:
        middle = (landmarks[LIP_INNER[below]] + landmarks[LIP_INNER[above]]) / 2
        landmarks[LIP_INNER[below]] = landmarks[LIP_INNER[above]] = middle
    return landmarks


def close_up(shape: tuple[int, int], lens: tuple[float, float, float, float], score: float, note: str
             ) -> RegionFound:
    """A close-up of lips (H, W): the whole image is read; the lips are the lens `lens` (LENS_SHAPES)."""
    height, width = shape
    mask = lens_mask(lens, height, width).astype(np.float32)
    empty = np.zeros((0, 2), np.float32)
    return RegionFound(mask, (0, 0, width, height), lens_outline(lens, height, width), empty, "close-up", 0,
                       float(score), note)


def cached_locator(detector_path: str | Path, landmarks_path: str | Path) -> LipsLocator:
    """A LipsLocator on the cached FaceReader of these model files (vto_core.photo.face_reader.cached_reader)."""
    return LipsLocator(cached_reader(detector_path, landmarks_path))
