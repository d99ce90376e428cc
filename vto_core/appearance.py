"""What a photo shows of a material in a region (the lips, the hair): colour statistics a fit through the renderer
can match when the photo's own scene is unknown.

The statistics are CIELAB: the region's mean colour (the colour an artist names, weighted double), the spread of its
lightness (shadows to highlights: gloss and shine show there) and of its chroma axes. They do not depend on the
region's size or shape, so a photo's lips and the default scene's lips compare directly.
"""

from __future__ import annotations

import numpy as np

from .colour import srgb_to_lab
from .errors import VtoError

LIGHTNESS_QUANTILES = (0.1, 0.5, 0.9, 0.98)  # 0.98: the highlights
CHROMA_QUANTILES = (0.25, 0.75)
MEAN_WEIGHT = 2.0
MIN_PIXELS = 4


def region_pixels(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """rgb (H, W, 3) display values and mask (H, W) (> 0.5 is the region) -> (N, 3) the region's pixels in [0, 1]."""
    rgb = np.asarray(rgb, np.float32)
    mask = np.nan_to_num(np.asarray(mask, np.float32), nan=0.0) > 0.5
    if rgb.ndim != 3 or rgb.shape[2] != 3 or mask.shape != rgb.shape[:2]:
        raise VtoError(f"a region is an (H, W, 3) image and an (H, W) mask, got {rgb.shape} and {mask.shape}")
    pixels = np.clip(np.nan_to_num(rgb[mask], nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    if len(pixels) < MIN_PIXELS:
        raise VtoError(f"the region has {len(pixels)} pixel(s); at least {MIN_PIXELS} are needed to read its colour")
    return pixels


def mean_colour(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The region's mean display colour (3,) in [0, 1]: what 'the photo's lip colour' or 'hair colour' means here."""
    return region_pixels(rgb, mask).mean(axis=0, dtype=np.float64)


def body_colour(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The region's per-channel median display colour (3,): its colour without the highlights and shadows."""
    return np.median(region_pixels(rgb, mask), axis=0)


def region_statistics(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(H, W, 3) display image and (H, W) mask -> (13,) float64: CIELAB of the mean colour (x MEAN_WEIGHT), lightness
    at LIGHTNESS_QUANTILES, a* and b* at CHROMA_QUANTILES. Finite for any finite or non-finite input."""
    pixels = region_pixels(rgb, mask)
    mean_lab = srgb_to_lab(pixels.mean(axis=0)).astype(np.float64)
    lab = srgb_to_lab(pixels).astype(np.float64)
    return np.concatenate([MEAN_WEIGHT * mean_lab, np.quantile(lab[:, 0], LIGHTNESS_QUANTILES),
                           np.quantile(lab[:, 1], CHROMA_QUANTILES), np.quantile(lab[:, 2], CHROMA_QUANTILES)])


def skin_around(lips: np.ndarray) -> np.ndarray:
    """The skin beside, above and below the lips: (H, W) lips mask -> (H, W) bool, a box 1.3x the lips' width and as
    high as it is wide, centred on them, less the lips' own box grown by a tenth of their width (no teeth, no
    mouth). Clipped to the image; empty for an empty mask."""
    lips = np.nan_to_num(np.asarray(lips, np.float32), nan=0.0) > 0.5
    skin = np.zeros(lips.shape, bool)
    if not lips.any():
        return skin
    rows, cols = np.nonzero(lips)
    width = cols.max() + 1 - cols.min()
    centre_y, centre_x = (rows.min() + rows.max() + 1) / 2, (cols.min() + cols.max() + 1) / 2
    y, x = np.mgrid[:lips.shape[0], :lips.shape[1]] + 0.5
    skin[(np.abs(x - centre_x) < 0.65 * width) & (np.abs(y - centre_y) < 0.5 * width)] = True
    grow = 0.1 * width
    lips_box = ((x > cols.min() - grow) & (x < cols.max() + 1 + grow) & (y > rows.min() - grow)
                & (y < rows.max() + 1 + grow))
    skin[lips_box] = False
    return skin


def skin_colour(rgb: np.ndarray, lips: np.ndarray) -> np.ndarray | None:
    """The mean linear RGB (3,) of the skin around the lips (skin_around), or None where fewer than MIN_PIXELS of it
    are in the image (a close crop)."""
    from .colour import srgb_to_linear

    skin = skin_around(lips)
    if skin.sum() < MIN_PIXELS:
        return None
    return srgb_to_linear(region_pixels(rgb, skin)).mean(axis=0, dtype=np.float64)


def skin_light(rgb: np.ndarray, lips: np.ndarray) -> tuple[float, np.ndarray] | None:
    """How the skin around the lips is lit: (its mean linear luminance, its mean CIELAB (3,)), or None where fewer
    than MIN_PIXELS of it are in the image (a close crop)."""
    from .colour import luminance, srgb_to_linear

    skin = skin_around(lips)
    if skin.sum() < MIN_PIXELS:
        return None
    pixels = region_pixels(rgb, skin)
    return float(luminance(srgb_to_linear(pixels)).mean()), srgb_to_lab(pixels.mean(axis=0)).astype(np.float64)

