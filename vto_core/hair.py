"""Numpy reference of the hair-colour stage (paper 4.2), step for step what the compositor groups compute."""

from __future__ import annotations

import numpy as np

from .colour import recolour_swatch
from .errors import VtoError
from .histogram import HistogramMatch, fit_histogram_match

SWATCH_PARAMS = ("brightness", "contrast", "exposure", "gamma", "hue", "saturation")
# A photo's hair is given the stage at full effect on all the hair: intensity 1 (the photo's colour, not a mix with
# the artist's own) and blend -1 (no fade). Those are the spec's defaults, and the fits hold them there.
PHOTO_HAIR = {"intensity": 1.0, "blend": -1.0}
LUT_POINTS = 64
MAX_LUT_SLOPE = 4.0  # contrast-limited matching (histogram.limit_slope): see fit_hair_match
# Faded look: weight = clamp(BLEND_RAMP * (t - offset)), offset = BLEND_OFFSET + BLEND_SCALE * blend, t = 0 at the top
# of the hair and 1 at its bottom. The ramp spans half the hair's height; blend = -1 puts it just above the top
# (all hair coloured), +1 at the bottom (none), and every blend in between moves it.
BLEND_RAMP = 2.0
BLEND_OFFSET, BLEND_SCALE = 0.25, 0.75
# Shine = global contrast (an S-curve) + local contrast (unsharp mask with a Gaussian of radius LOCAL_RADIUS x width,
# the compositor Blur node's Gaussian: sigma = radius / 3, edges extended).
GLOBAL_CONTRAST_GAIN = 2.0
LOCAL_CONTRAST_GAIN = 1.0
LOCAL_RADIUS = 0.05
CURVE_TABLE_POINTS = 257  # Blender tabulates a curve at 257 points over [0, 1]
SQUARE_LOOKAHEAD = 8  # sides past the bisected largest square that hair_square also tries


def hair_gradient(mask: np.ndarray) -> np.ndarray:
    """Vertical position inside the hair's bounding box: mask (H, W) -> t (H, W) float32, 0 at the top row.

    Rows above the hair are 0, rows below 1; an empty mask gives zeros.
    """
    inside = np.asarray(mask) > 0.5
    rows = np.nonzero(inside.any(axis=1))[0]
    height, width = inside.shape
    if rows.size == 0:
        return np.zeros((height, width), np.float32)
    top, bottom = rows[0], rows[-1]
    t = (np.arange(height) - top) / max(bottom - top, 1)
    return np.broadcast_to(np.clip(t, 0, 1)[:, None], (height, width)).astype(np.float32)


def blur_radius(width: int) -> int:
    """The local-contrast blur radius in pixels for an image `width` pixels wide."""
    return max(1, round(LOCAL_RADIUS * width))


def gaussian_blur(rgb: np.ndarray, radius: int) -> np.ndarray:
    """Blender's compositor Gaussian Blur: (H, W, C) -> (H, W, C), weights exp(-(3 i / radius)^2 / 2), |i| <= radius,
    edges extended."""
    offsets = np.arange(-radius, radius + 1)
    weights = np.exp(-0.5 * (3.0 * offsets / radius) ** 2)
    weights /= weights.sum()
    padded = np.pad(np.asarray(rgb, np.float64), ((radius, radius), (radius, radius), (0, 0)), mode="edge")
    height, width = rgb.shape[:2]
    rows = sum(w * padded[k: k + height] for k, w in enumerate(weights))
    return sum(w * rows[:, k: k + width] for k, w in enumerate(weights)).astype(np.float32)


def shine(rgb: np.ndarray, amount: float, blurred: np.ndarray | None = None) -> np.ndarray:
    """Global and local contrast, per channel: (..., 3) -> (..., 3) in [0, 1].

    y + amount * GLOBAL_CONTRAST_GAIN * (smoothstep(y) - y) + amount * LOCAL_CONTRAST_GAIN * (y - blurred),
    y = clip(rgb, 0, 1);
    `blurred` is gaussian_blur of y (None: no local term).
    """
    y = np.clip(rgb, 0.0, 1.0)
    out = y + amount * GLOBAL_CONTRAST_GAIN * (y * y * (3.0 - 2.0 * y) - y)
    if blurred is not None:
        out = out + amount * LOCAL_CONTRAST_GAIN * (y - blurred)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def blend_weight(gradient: np.ndarray, blend: float) -> np.ndarray:
    """Faded look: clamp(BLEND_RAMP * (t - BLEND_OFFSET - BLEND_SCALE * blend)); -1 colours all, 1 nothing."""
    offset = BLEND_OFFSET + BLEND_SCALE * blend
    return np.clip(BLEND_RAMP * (np.asarray(gradient, np.float32) - offset), 0.0, 1.0).astype(np.float32)


def swatch_target(swatch: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """Pass 1: the reference swatch (h, w, 3) recoloured by the swatch parameters."""
    return recolour_swatch(swatch, *(values[name] for name in SWATCH_PARAMS))


def fit_hair_match(source: np.ndarray, mask: np.ndarray, recoloured_swatch: np.ndarray) -> HistogramMatch:
    """The LUTs that move the masked hair's R, G and B histograms onto the recoloured swatch's.

    source (H, W, 3) and mask (H, W) must be finite everywhere (VtoError otherwise), swatch (h, w, 3).
    No gray curve: after the channel curves (the only order Blender's RGB Curves node has) it pulled the channels
    2.4-3.9x further from the swatch (Wasserstein-1) and left gray no closer; first (folded into the channel curves)
    it was worse too. Slopes are capped at MAX_LUT_SLOPE: uncapped, a narrow band of bright source values was spread
    over the swatch's sparse highlights, turning render noise into coloured speckles. The trade, from
    benchmarks/results/hair_match.md: mean W1 to the swatch 0.51 -> 1.32/255, block noise after matching 0.97 ->
    0.86 of the source's, and the weakest parameter's visibility, averaged over sources, 3.53 -> 3.98.
    """
    if not (np.isfinite(source).all() and np.isfinite(mask).all()):
        raise VtoError("hair source or mask has NaN or inf pixels")
    return fit_histogram_match(source, recoloured_swatch, source_mask=mask, n_points=LUT_POINTS, match_gray=False,
                               max_slope=MAX_LUT_SLOPE)


def apply_curves_node(rgb: np.ndarray, match: HistogramMatch) -> np.ndarray:
    """match.apply as Blender's RGB Curves node computes it: (..., 3) -> (..., 3) float32.

    Blender folds the C (gray) curve into each channel's table: table_c[k] = C(channel_c(t_k)) at 257 points
    t_k, then interpolates that table linearly. Where C is steep this differs from C(channel_c(x)).
    """
    t = np.linspace(0.0, 1.0, CURVE_TABLE_POINTS)
    gray_table = np.interp(t, *match.gray_lut)
    channels = []
    for c, lut in enumerate(match.channel_luts):
        folded = np.interp(np.interp(t, *lut), t, gray_table)
        channels.append(np.interp(np.clip(rgb[..., c], 0.0, 1.0), t, folded))
    return np.stack(channels, axis=-1).astype(np.float32)


def apply_hair_stage(source: np.ndarray, mask: np.ndarray, gradient: np.ndarray, match: HistogramMatch,
                     values: dict[str, float]) -> np.ndarray:
    """Pass 2: LUT, shine, then mix into the source by mask * blend weight * intensity: (H, W, 3) in [0, 1].

    The stage works on display values: a source above 1 (HDR) or below 0 is clipped first, as
    blender_addon.renderers.hair stages it.
    """
    if source.shape[:2] != np.shape(mask) or np.shape(mask) != np.shape(gradient):
        raise VtoError(f"source {source.shape[:2]}, mask {np.shape(mask)} and gradient {np.shape(gradient)} differ in size")
    source = np.clip(source, 0.0, 1.0)
    curved = np.clip(apply_curves_node(source, match), 0.0, 1.0)
    recoloured = shine(curved, values["shine"], gaussian_blur(curved, blur_radius(source.shape[1])))
    alpha = np.clip(mask, 0, 1) * blend_weight(gradient, values["blend"]) * values["intensity"]
    return (source + alpha[..., None] * (recoloured - source)).astype(np.float32)


def render_hair_reference(source: np.ndarray, mask: np.ndarray, swatch: np.ndarray, values: dict[str, float]) -> np.ndarray:
    """The whole stage in numpy: source (H, W, 3) display values, mask (H, W), swatch (h, w, 3) -> (H, W, 3)."""
    match = fit_hair_match(source, mask, swatch_target(swatch, values))
    return apply_hair_stage(source, mask, hair_gradient(mask), match, values)


def hair_square(mask: np.ndarray, share: float = 0.98, smallest: float = 0.0) -> tuple[int, int, int] | None:
    """The largest square of a hair mask (H, W) whose pixels are at least `share` hair: (x, y, side) from the
    top-left, the one nearest the centre among equals; None when no square of at least max(8, smallest * min(H, W))
    px qualifies. Used to cut a hair region (what an encoder reads) from a render or a masked photo."""
    mask = np.nan_to_num(np.asarray(mask, np.float64), nan=0.0) > 0.5
    height, width = mask.shape
    table = np.zeros((height + 1, width + 1))
    table[1:, 1:] = mask.cumsum(0).cumsum(1)
    low = max(8, int(np.ceil(smallest * min(height, width))))

    def squares(side: int) -> tuple[np.ndarray, np.ndarray]:
        inside = (table[side:, side:] - table[:-side, side:] - table[side:, :-side] + table[:-side, :-side])
        return np.nonzero(inside >= share * side * side)

    # A square that qualifies holds smaller ones that (nearly always) do: bisect for the largest side, then look a
    # few sides further for the rare larger one that a smaller failing side hid.
    lowest, highest = low, min(height, width)
    if highest < low or not len(squares(low)[0]):
        return None
    while lowest < highest:
        middle = (lowest + highest + 1) // 2
        lowest, highest = (middle, highest) if len(squares(middle)[0]) else (lowest, middle - 1)
    best_side = lowest
    for side in range(lowest + 1, min(min(height, width), lowest + SQUARE_LOOKAHEAD) + 1):
        best_side = side if len(squares(side)[0]) else best_side
    rows, cols = squares(best_side)
    centre = np.hypot(rows + best_side / 2 - height / 2, cols + best_side / 2 - width / 2)
    best = int(np.argmin(centre))
    return int(cols[best]), int(rows[best]), best_side
