"""Is there colour in a photo to read? A black-and-white photo, or a toned print (sepia, cyanotype), has none.

In a toned print every pixel's colour follows from its lightness alone (one hue, its chroma a function of L*); in a
black-and-white one the chroma is zero. A colour photo shows different colours at the same lightness: skin, lips,
hair, clothes and background. So the measure is the chroma left once each lightness band's mean colour is taken
out (`colour_spread`, CIELAB units, RMS over the photo reduced to SPREAD_SIZE px). Measured on the 18 portraits of
benchmarks/photos (benchmarks/results/photo_forms.md): colour 11-36, the same desaturated to 40 % 4.7-16, a landscape
6.1; their black-and-white, sepia and cyanotype JPEGs 0.0-0.62. numpy only, so this runs inside Blender's extension.

Shapes: images (H, W, 3) display sRGB in [0, 1].
"""

from __future__ import annotations

import math

import numpy as np

from ..colour import srgb_to_lab
from .face_reader import as_rgb, reduce

SPREAD_SIZE = 128  # px on the longer side: the photo is reduced (block means) to about this before it is measured
BAND = 4.0  # L* units per lightness band
GREY_CHROMA = 1.0  # a photo whose 99th-percentile chroma stays under this is black and white
MIN_SPREAD = 1.5  # a photo whose colour_spread stays under this is monochrome (toned)
FLAT_LIGHTNESS = 2.0  # L* range under which a picture is flat (blank, black): nothing to judge


def lab_of(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) -> (N, 3) float64 CIELAB of the image reduced to about SPREAD_SIZE px (NaN and HDR cleaned): every
    step-th pixel to twice that size, then 2 x 2 block means (a megapixel photo in ~2 ms, where a full reduce took
    ~20)."""
    image = as_rgb(image)
    step = max(1, math.ceil(max(image.shape[:2]) / (2 * SPREAD_SIZE)))
    image = np.asarray(image[::step, ::step], np.float32)
    image = np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    return srgb_to_lab(reduce(image, 2) if min(image.shape[:2]) >= 2 else image).reshape(-1, 3).astype(np.float64)


def colour_spread(lab: np.ndarray) -> float:
    """RMS chroma (CIELAB) not explained by lightness: each pixel's (a*, b*) less its lightness band's mean."""
    if not len(lab):
        return 0.0
    bands = np.clip((lab[:, 0] / BAND).astype(np.int64), 0, int(100 / BAND))
    counts = np.maximum(np.bincount(bands, minlength=bands.max() + 1), 1)
    means = np.stack([np.bincount(bands, lab[:, k], minlength=len(counts)) / counts for k in (1, 2)], axis=1)
    return float(np.sqrt(((lab[:, 1:] - means[bands]) ** 2).sum(axis=1).mean()))


def grey_chroma(lab: np.ndarray) -> float:
    """The 99th-percentile chroma (CIELAB) of the pixels: near 0 for a black-and-white photo."""
    return float(np.percentile(np.hypot(lab[:, 1], lab[:, 2]), 99)) if len(lab) else 0.0


def monochrome_problem(image: np.ndarray, product: str, toned: bool = True) -> str:
    """'' where (H, W, 3) shows colour; else one line saying why no `product` ('lipstick', 'hair') colour can be read.

    toned=False checks black and white only: a patch of grey or white hair is near one hue too. A picture of one
    flat lightness (blank, black) is left to the locators: it shows nothing to judge."""
    lab = lab_of(image)
    if np.ptp(lab[:, 0]) < FLAT_LIGHTNESS:
        return ""
    if grey_chroma(lab) < GREY_CHROMA:
        return f"a black-and-white photo has no {product} colour to read: choose a colour photo"
    if toned and colour_spread(lab) < MIN_SPREAD:
        return (f"a monochrome (toned) print has no {product} colour to read: every pixel has one hue; choose a colour "
                "photo")
    return ""
