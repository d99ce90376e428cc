"""Masked histogram matching as monotone piecewise-linear LUTs for Blender's RGB Curves node."""

import warnings
from dataclasses import dataclass

import numpy as np

from vto_core.colour import luminance
from vto_core.errors import VtoError

# A source spread below this is treated as constant: its CDF carries no usable shape.
_CONSTANT_SPREAD = 1e-6

_EMPTY_MASK_MESSAGE = "histogram match: the source mask is empty; using identity LUTs"


def _finite_values(values, name):
    """Any float array-like -> flat float64 ndarray; VtoError naming `name` if it holds NaN or inf."""
    flat = np.asarray(values, dtype=np.float64).ravel()
    if not np.all(np.isfinite(flat)):
        raise VtoError(f"{name} contains NaN or inf")
    return flat


def _check_n_points(n_points):
    """Raise VtoError unless n_points is an integer >= 2."""
    is_number = isinstance(n_points, (int, float, np.number)) and not isinstance(n_points, bool)
    if not is_number or not float(n_points).is_integer() or n_points < 2:
        raise VtoError(f"n_points must be an integer >= 2, got {n_points!r}")
    return int(n_points)


def _identity_lut(n_points):
    """n_points -> (lut_x, lut_y), both (n_points,) float32 with lut_y = lut_x."""
    lut_x = np.linspace(0.0, 1.0, n_points, dtype=np.float32)
    return lut_x, lut_x.copy()


def _match_checked(source, reference, n_points):
    """Flat finite float64 source (non-empty) and reference (non-empty) -> (lut_x, lut_y) float32."""
    source = np.clip(source, 0.0, 1.0)
    reference = np.clip(reference, 0.0, 1.0)
    lut_x = np.linspace(0.0, 1.0, n_points)
    if np.ptp(source) < _CONSTANT_SPREAD or np.ptp(reference) < _CONSTANT_SPREAD:
        lut_y = np.full(n_points, np.median(reference))
    else:
        sorted_source = np.sort(source)
        count_below = np.searchsorted(sorted_source, lut_x, side="left")
        count_at_or_below = np.searchsorted(sorted_source, lut_x, side="right")
        # Mid-rank CDF: ties count half, so a sample matched to itself stays near identity.
        source_cdf = (count_below + count_at_or_below) / (2.0 * source.size)
        lut_y = np.maximum.accumulate(np.quantile(reference, source_cdf))
    return lut_x.astype(np.float32), np.clip(lut_y, 0.0, 1.0).astype(np.float32)


def limit_slope(lut_x, lut_y, source_values, max_slope):
    """Contrast-limited LUT: lut_x, lut_y (K,), source (N,) -> lut_y (K,) float32 with every slope <= max_slope.

    Steeper steps are cut to max_slope (where a narrow band of source values spreads over a sparse reference tail,
    a step would multiply the source's noise by its slope); the capped curve is then shifted so that the mean of the
    mapped source values stays what the uncapped LUT gives, and clipped to [0, 1]: the colour is kept, the tails
    give way.
    """
    lut_x = np.asarray(lut_x, dtype=np.float64)
    lut_y = np.asarray(lut_y, dtype=np.float64)
    if not max_slope > 0:
        raise VtoError(f"max_slope must be positive, got {max_slope}")
    steps = np.minimum(np.diff(lut_y), max_slope * np.diff(lut_x))
    capped = lut_y[0] + np.concatenate([[0.0], np.cumsum(steps)])
    source = np.clip(np.asarray(source_values, dtype=np.float64).ravel(), 0.0, 1.0)
    if source.size:
        capped += np.mean(np.interp(source, lut_x, lut_y) - np.interp(source, lut_x, capped))
    return np.clip(capped, 0.0, 1.0).astype(np.float32)


def match_lut(source_values, reference_values, n_points=64):
    """source (N,), reference (M,) float -> (lut_x, lut_y), each (n_points,) float32, lut_y monotone in [0, 1]."""
    n_points = _check_n_points(n_points)
    source = _finite_values(source_values, "source_values")
    reference = _finite_values(reference_values, "reference_values")
    if reference.size == 0:
        raise VtoError("reference_values is empty (reference mask selects no pixels)")
    if source.size == 0:
        warnings.warn(_EMPTY_MASK_MESSAGE, stacklevel=2)
        return _identity_lut(n_points)
    return _match_checked(source, reference, n_points)


def apply_lut(values, lut_x, lut_y):
    """values: (...) float, lut_x/lut_y: (K,) -> (...) float32, piecewise linear on values clipped to [0, 1]."""
    lut_x = np.asarray(lut_x, dtype=np.float64)
    lut_y = np.asarray(lut_y, dtype=np.float64)
    if lut_x.ndim != 1 or lut_x.shape != lut_y.shape or lut_x.size < 2:
        raise VtoError(f"lut_x and lut_y must be 1-D, equal length >= 2, got {lut_x.shape} and {lut_y.shape}")
    clipped = np.clip(np.asarray(values, dtype=np.float64), 0.0, 1.0)
    return np.interp(clipped, lut_x, lut_y).astype(np.float32)


@dataclass(frozen=True)
class HistogramMatch:
    """One LUT per channel, then a gray LUT on every channel: the order Blender's RGB Curves applies R, G, B then C."""

    gray_lut: tuple
    channel_luts: tuple

    def apply(self, rgb):
        """rgb: (..., 3) float -> (..., 3) float32, out_c = gray_lut(channel_lut_c(x_c))."""
        rgb = np.asarray(rgb, dtype=np.float64)
        if rgb.ndim == 0 or rgb.shape[-1] != 3:
            raise VtoError(f"rgb must have shape (..., 3), got {rgb.shape}")
        channel_mapped = np.stack(
            [apply_lut(rgb[..., channel], *self.channel_luts[channel]) for channel in range(3)], axis=-1
        )
        return apply_lut(channel_mapped, *self.gray_lut)


def _inside_mask(rgb, mask, rgb_name, mask_name):
    """rgb (H, W, 3), mask (H, W) bool/float or None -> (N, 3) float64 pixels where mask > 0.5."""
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.ndim != 3 or rgb.shape[-1] != 3:
        raise VtoError(f"{rgb_name} must have shape (H, W, 3), got {rgb.shape}")
    if mask is None:
        return rgb.reshape(-1, 3)
    mask = np.asarray(mask)
    if mask.shape != rgb.shape[:2]:
        raise VtoError(f"{mask_name} shape {mask.shape} does not match {rgb_name} shape {rgb.shape[:2]}")
    inside = mask if mask.dtype == bool else mask > 0.5
    return rgb[inside]


def fit_histogram_match(source_rgb, reference_rgb, source_mask=None, reference_mask=None, n_points=64,
                        match_gray=True, max_slope=None):
    """source_rgb (H, W, 3), reference_rgb (h, w, 3), masks (H, W) / (h, w) or None -> HistogramMatch.

    With match_gray=False the gray LUT stays the identity: the R, G, B matches alone. With max_slope, every
    channel LUT goes through limit_slope (the gray LUT is then fitted on the capped channels).
    """
    n_points = _check_n_points(n_points)
    source_pixels = _inside_mask(source_rgb, source_mask, "source_rgb", "source_mask")
    reference_pixels = _inside_mask(reference_rgb, reference_mask, "reference_rgb", "reference_mask")
    # Only the selected pixels are checked: whatever lies outside the masks cannot affect the LUTs.
    _finite_values(source_pixels, "source_rgb (inside source_mask)")
    _finite_values(reference_pixels, "reference_rgb (inside reference_mask)")
    if reference_pixels.shape[0] == 0:
        raise VtoError("reference_rgb has no pixels inside reference_mask")
    if source_pixels.shape[0] == 0:
        warnings.warn(_EMPTY_MASK_MESSAGE, stacklevel=2)
        return HistogramMatch(
            gray_lut=_identity_lut(n_points),
            channel_luts=tuple(_identity_lut(n_points) for _ in range(3)),
        )

    channel_luts = tuple(
        _match_checked(source_pixels[:, channel], reference_pixels[:, channel], n_points) for channel in range(3)
    )
    if max_slope is not None:
        channel_luts = tuple((lut_x, limit_slope(lut_x, lut_y, source_pixels[:, channel], max_slope))
                             for channel, (lut_x, lut_y) in enumerate(channel_luts))
    channel_mapped = np.stack(
        [apply_lut(source_pixels[:, channel], *channel_luts[channel]) for channel in range(3)], axis=-1
    ).astype(np.float64)
    channel_gray = luminance(channel_mapped).astype(np.float64)
    if not match_gray or np.ptp(channel_gray) < _CONSTANT_SPREAD:
        # A constant LUT here would paint every channel one gray; the channel LUTs already did the match.
        gray_lut = _identity_lut(n_points)
    else:
        gray_lut = _match_checked(channel_gray, luminance(reference_pixels).astype(np.float64), n_points)
    return HistogramMatch(gray_lut=gray_lut, channel_luts=channel_luts)
