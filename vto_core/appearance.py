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
LAB_CHUNK = 1 << 20  # pixels converted to CIELAB at a time (lab_of_pixels)


def region_pixels(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """rgb (H, W, 3) display values and mask (H, W) (> 0.5 is the region) -> (N, 3) the region's pixels in [0, 1]."""
    rgb = np.asarray(rgb, np.float32)
    mask = np.asarray(mask)
    mask = mask if mask.dtype == bool else np.asarray(mask, np.float32) > 0.5  # NaN is outside
    if rgb.ndim != 3 or rgb.shape[2] != 3 or mask.shape != rgb.shape[:2]:
        raise VtoError(f"a region is an (H, W, 3) image and an (H, W) mask, got {rgb.shape} and {mask.shape}")
    pixels = rgb[mask]  # a copy of the region's pixels, cleaned in place
    np.clip(np.nan_to_num(pixels, copy=False, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0, out=pixels)
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
    lab = lab_of_pixels(pixels)
    return np.concatenate([MEAN_WEIGHT * mean_lab, np.quantile(lab[:, 0], LIGHTNESS_QUANTILES),
                           np.quantile(lab[:, 1], CHROMA_QUANTILES), np.quantile(lab[:, 2], CHROMA_QUANTILES)])


def lab_of_pixels(pixels: np.ndarray) -> np.ndarray:
    """(N, 3) display pixels -> (N, 3) float64 CIELAB (srgb_to_lab, the same values), LAB_CHUNK pixels at a time: a
    large region (the hair of a 64-megapixel portrait) makes no region-sized float64 temporaries."""
    lab = np.empty((len(pixels), 3), np.float64)
    for start in range(0, len(pixels), LAB_CHUNK):
        lab[start:start + LAB_CHUNK] = srgb_to_lab(pixels[start:start + LAB_CHUNK])
    return lab


def skin_around(region: np.ndarray) -> np.ndarray:
    """The skin beside, above and below a face region (the lips): (H, W) region mask -> (H, W) bool, a box 1.3x the
    region's width and as high as it is wide, centred on it, less the region's own box grown by a tenth of its width
    (no teeth, no mouth). Clipped to the image; empty for an empty mask."""
    skin = np.zeros(np.shape(region)[:2], bool)
    found = skin_box(region)
    if found is not None:
        (y0, y1, x0, x1), inside = found
        skin[y0:y1, x0:x1] = inside
    return skin


def skin_box(region: np.ndarray) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
    """skin_around without a whole-image mask: ((y0, y1, x0, x1) the rows and columns the skin spans, (y1 - y0,
    x1 - x0) bool the skin inside them), or None for an empty mask or no skin. Per axis, so a 64-megapixel photo's
    region cost a few vectors, not whole-image grids."""
    region = np.asarray(region)
    region = region if region.dtype == bool else np.asarray(region, np.float32) > 0.5  # NaN is outside
    rows, cols = np.flatnonzero(region.any(axis=1)), np.flatnonzero(region.any(axis=0))
    if not rows.size:
        return None
    width = cols.max() + 1 - cols.min()
    centre_y, centre_x = (rows.min() + rows.max() + 1) / 2, (cols.min() + cols.max() + 1) / 2
    y, x = np.arange(region.shape[0]) + 0.5, np.arange(region.shape[1]) + 0.5
    grow = 0.1 * width
    in_rows = np.flatnonzero(np.abs(y - centre_y) < 0.5 * width)
    in_cols = np.flatnonzero(np.abs(x - centre_x) < 0.65 * width)
    if not in_rows.size or not in_cols.size:
        return None
    y0, y1, x0, x1 = in_rows[0], in_rows[-1] + 1, in_cols[0], in_cols[-1] + 1
    y, x = y[y0:y1], x[x0:x1]
    region_rows = (y > rows.min() - grow) & (y < rows.max() + 1 + grow)
    region_cols = (x > cols.min() - grow) & (x < cols.max() + 1 + grow)
    return (int(y0), int(y1), int(x0), int(x1)), ~(region_rows[:, None] & region_cols[None, :])


def skin_colour(rgb: np.ndarray, region: np.ndarray) -> np.ndarray | None:
    """The mean linear RGB (3,) of the skin around the region (skin_around), or None where fewer than MIN_PIXELS of it
    are in the image (a close crop)."""
    from .colour import srgb_to_linear

    pixels = _skin_pixels(rgb, region)
    return None if pixels is None else srgb_to_linear(pixels).mean(axis=0, dtype=np.float64)


def _skin_pixels(rgb: np.ndarray, region: np.ndarray, below: bool = False) -> np.ndarray | None:
    """region_pixels of the skin around the region (skin_around; `below`: only its rows below the region's lowest),
    read inside the skin's box only; None where fewer than MIN_PIXELS of it are in the image."""
    found = skin_box(region)
    if found is None:
        return None
    (y0, y1, x0, x1), skin = found
    if below:
        lowest = np.flatnonzero((np.nan_to_num(np.asarray(region, np.float32)) > 0.5).any(axis=1)).max()
        skin = skin & (np.arange(y0, y1) > lowest)[:, None]
    if skin.sum() < MIN_PIXELS:
        return None
    rgb = np.asarray(rgb)
    if rgb.shape[:2] != np.shape(region)[:2]:
        raise VtoError(f"a region is an (H, W, 3) image and an (H, W) mask, got {rgb.shape} and {np.shape(region)}")
    return region_pixels(rgb[y0:y1, x0:x1], skin)


def skin_below(rgb: np.ndarray, region: np.ndarray) -> np.ndarray | None:
    """The per-channel median linear RGB (3,) of the skin around the region (skin_around) below its lowest row: under
    an eye's lid, the cheek, which a fringe of hair or the brows above the lid do not reach. None where fewer than
    MIN_PIXELS of it are in the image."""
    from .colour import srgb_to_linear

    pixels = _skin_pixels(rgb, region, below=True)
    return None if pixels is None else np.median(srgb_to_linear(pixels), axis=0).astype(np.float64)


def skin_light(rgb: np.ndarray, region: np.ndarray) -> tuple[float, np.ndarray] | None:
    """How the skin around the region is lit: (its mean linear luminance, its mean CIELAB (3,)), or None where fewer
    than MIN_PIXELS of it are in the image (a close crop)."""
    from .colour import luminance, srgb_to_linear

    pixels = _skin_pixels(rgb, region)
    if pixels is None:
        return None
    return float(luminance(srgb_to_linear(pixels)).mean()), srgb_to_lab(pixels.mean(axis=0)).astype(np.float64)

