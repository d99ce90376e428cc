"""Colour conversions and the hair swatch recolouring, as numpy references for Blender's nodes."""

import numpy as np

from vto_core.errors import VtoError

LUMA_WEIGHTS = (0.2126, 0.7152, 0.0722)

_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _as_float64(values):
    """Any float array-like -> float64 ndarray (internal maths run in float64)."""
    return np.asarray(values, dtype=np.float64)


def _to_float32(values):
    """float64 ndarray -> float32, saturating at the float32 range so finite stays finite."""
    return np.clip(values, -_FLOAT32_MAX, _FLOAT32_MAX).astype(np.float32)


def _require_rgb_last_axis(values, name):
    """Raise VtoError unless values has a last axis of length 3."""
    if values.ndim == 0 or values.shape[-1] != 3:
        raise VtoError(f"{name} must have shape (..., 3), got {values.shape}")


def _srgb_to_linear(srgb):
    """(...) float64 (or float32, computed in it) -> the same, IEC 61966-2-1 decoding with negatives sent to 0."""
    # The power branch is evaluated everywhere by np.where, so keep its base non-negative.
    power_base = np.maximum((srgb + 0.055) / 1.055, 0.0)
    with np.errstate(over="ignore"):
        power_branch = power_base**2.4
    linear_branch = np.where(srgb < 0.0, 0.0, srgb / 12.92)
    return np.where(srgb < 0.04045, linear_branch, power_branch)


def _linear_to_srgb64(linear):
    """(...) float64 -> (...) float64, IEC 61966-2-1 encoding with negatives sent to 0."""
    power_branch = 1.055 * np.maximum(linear, 0.0) ** (1.0 / 2.4) - 0.055
    linear_branch = np.where(linear < 0.0, 0.0, linear * 12.92)
    return np.where(linear < 0.0031308, linear_branch, power_branch)


def _rgb_to_hsv64(rgb):
    """(..., 3) float64 -> (..., 3) float64 hexcone HSV with h in [0, 1)."""
    red, green, blue = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    value = rgb.max(axis=-1)
    chroma = value - rgb.min(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        saturation = np.where(value == 0.0, 0.0, chroma / value)
        safe_chroma = np.where(chroma == 0.0, 1.0, chroma)
        hue_sextant = np.where(
            value == red,
            ((green - blue) / safe_chroma) % 6.0,
            np.where(
                value == green,
                (blue - red) / safe_chroma + 2.0,
                (red - green) / safe_chroma + 4.0,
            ),
        )
    hue = np.where(chroma == 0.0, 0.0, hue_sextant / 6.0) % 1.0
    return np.stack([hue, saturation, value], axis=-1)


def _hsv_to_rgb64(hsv):
    """(..., 3) float64 -> (..., 3) float64 with Blender's formula (linear in s, also for s > 1)."""
    hue = hsv[..., 0] % 1.0
    saturation = hsv[..., 1:2]
    value = hsv[..., 2:3]
    pure_hue_rgb = np.stack(
        [
            np.clip(np.abs(6.0 * hue - 3.0) - 1.0, 0.0, 1.0),
            np.clip(2.0 - np.abs(6.0 * hue - 2.0), 0.0, 1.0),
            np.clip(2.0 - np.abs(6.0 * hue - 4.0), 0.0, 1.0),
        ],
        axis=-1,
    )
    with np.errstate(over="ignore", invalid="ignore"):
        return ((pure_hue_rgb - 1.0) * saturation + 1.0) * value


def srgb_to_linear(srgb):
    """srgb: (...) float -> (...) float32 linear; negatives -> 0, values > 1 follow the power law."""
    return _to_float32(_srgb_to_linear(_as_float64(srgb)))


def linear_to_srgb(linear):
    """linear: (...) float -> (...) float32 sRGB-encoded; negatives -> 0, values > 1 follow the power law."""
    return _to_float32(_linear_to_srgb64(_as_float64(linear)))


def luminance(rgb):
    """rgb: (..., 3) float -> (...) float32, Rec. 709 weighted sum LUMA_WEIGHTS."""
    rgb = _as_float64(rgb)
    _require_rgb_last_axis(rgb, "rgb")
    with np.errstate(over="ignore", invalid="ignore"):
        return _to_float32(rgb @ np.asarray(LUMA_WEIGHTS))


def rgb_to_hsv(rgb):
    """rgb: (..., 3) float -> (..., 3) float32 hsv; v = max, s = (max - min) / max, h in [0, 1)."""
    rgb = _as_float64(rgb)
    _require_rgb_last_axis(rgb, "rgb")
    hsv = _to_float32(_rgb_to_hsv64(rgb))
    # A hue just below 1 in float64 can round up to 1.0 in float32; keep h in [0, 1).
    hsv[..., 0] = np.where(hsv[..., 0] >= 1.0, 0.0, hsv[..., 0])
    return hsv


def hsv_to_rgb(hsv):
    """hsv: (..., 3) float -> (..., 3) float32 rgb; h is taken modulo 1, s is not clamped."""
    hsv = _as_float64(hsv)
    _require_rgb_last_axis(hsv, "hsv")
    return _to_float32(_hsv_to_rgb64(hsv))


def recolour_swatch(rgb, brightness, contrast, exposure, gamma, hue, saturation):
    """rgb: (..., 3) float -> (..., 3) float32 in [0, 1]; the swatch recolouring of paper Table 3."""
    rgb = _as_float64(rgb)
    _require_rgb_last_axis(rgb, "rgb")
    if not np.all(np.isfinite(rgb)):
        raise VtoError("recolour_swatch: rgb contains NaN or inf")
    params = dict(
        brightness=brightness,
        contrast=contrast,
        exposure=exposure,
        gamma=gamma,
        hue=hue,
        saturation=saturation,
    )
    for name, param in params.items():
        if not np.isfinite(float(param)):
            raise VtoError(f"recolour_swatch: {name} must be finite, got {param}")
    if float(gamma) <= 0.0:
        raise VtoError(f"recolour_swatch: gamma must be > 0, got {gamma}")

    with np.errstate(over="ignore"):
        adjusted = (rgb - 0.5) * float(contrast) + 0.5 + float(brightness)
    # Saturate overflow so that inf * (exposure == 0) cannot turn into NaN.
    adjusted = np.clip(adjusted, -np.finfo(np.float64).max, np.finfo(np.float64).max)
    with np.errstate(over="ignore"):
        adjusted = adjusted * float(exposure)
    adjusted = np.clip(adjusted, 0.0, 1.0)
    adjusted = adjusted ** (1.0 / float(gamma))
    hsv = _rgb_to_hsv64(adjusted)
    hsv[..., 0] = (hsv[..., 0] + float(hue)) % 1.0
    hsv[..., 1] = hsv[..., 1] * float(saturation)
    return np.clip(_hsv_to_rgb64(hsv), 0.0, 1.0).astype(np.float32)


_SRGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                         [0.2126729, 0.7151522, 0.0721750],
                         [0.0193339, 0.1191920, 0.9503041]])
_D65_WHITE = np.array([0.95047, 1.0, 1.08883])
LAB_FLOAT32_LIMIT = 1e4  # |value| up to which float32 sRGB converts to CIELAB in float32 (2.4th power: no overflow)


def srgb_to_lab(srgb, fast: bool = False):
    """srgb: (..., 3) display values -> (..., 3) float32 CIELAB (D65; L in [0, 100] for [0, 1] input). With `fast`,
    float32 input whose values all lie within LAB_FLOAT32_LIMIT is converted in float32 arithmetic: 3x faster, within
    1e-4 of the float64 conversion on [0, 1] (a work grid's colours; statistics and fits keep float64)."""
    values = np.asarray(srgb)
    _require_rgb_last_axis(values, "srgb")
    if fast and values.dtype == np.float32 and np.all(np.abs(values) <= LAB_FLOAT32_LIMIT):  # NaN, inf fail the test
        return _srgb_to_lab(values, np.float32)
    return _to_float32(_srgb_to_lab(np.nan_to_num(_as_float64(values), nan=0.0, posinf=1.0, neginf=0.0), np.float64))


def _srgb_to_lab(srgb, dtype):
    """(..., 3) finite display values of `dtype` -> (..., 3) CIELAB of `dtype`, computed in it."""
    xyz = _srgb_to_linear(srgb) @ _SRGB_TO_XYZ.T.astype(dtype) / _D65_WHITE.astype(dtype)
    epsilon, kappa = dtype(216 / 24389), dtype(24389 / 27)
    f = np.where(xyz > epsilon, np.cbrt(xyz), (kappa * xyz + 16) / 116)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], -1)


def lightness_luminance(lightness: float) -> float:
    """CIELAB L* in [0, 100] -> the relative luminance Y in [0, 1] that has it (the inverse of _srgb_to_lab's L*)."""
    return ((lightness + 16.0) / 116.0) ** 3 if lightness > 8.0 else lightness * 27.0 / 24389.0


def relative_luminance(linear) -> float:
    """A linear sRGB colour (3,) -> its CIE relative luminance Y (the row of the sRGB -> XYZ matrix CIELAB reads)."""
    return float(_as_float64(linear) @ _SRGB_TO_XYZ[1])


def ciede2000(lab1, lab2):
    """CIEDE2000 colour difference of two CIELAB arrays (..., 3) -> (...) float64 (Sharma et al. 2005)."""
    lab1, lab2 = _as_float64(lab1), _as_float64(lab2)
    l1, a1, b1 = np.moveaxis(lab1, -1, 0)
    l2, a2, b2 = np.moveaxis(lab2, -1, 0)
    c_mean = (np.hypot(a1, b1) + np.hypot(a2, b2)) / 2
    g = 0.5 * (1 - np.sqrt(c_mean**7 / (c_mean**7 + 25.0**7)))
    a1p, a2p = (1 + g) * a1, (1 + g) * a2
    c1p, c2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1p, h2p = np.degrees(np.arctan2(b1, a1p)) % 360, np.degrees(np.arctan2(b2, a2p)) % 360
    dl, dc = l2 - l1, c2p - c1p
    dh = h2p - h1p
    dh = np.where(c1p * c2p == 0, 0.0, np.where(dh > 180, dh - 360, np.where(dh < -180, dh + 360, dh)))
    dhh = 2 * np.sqrt(c1p * c2p) * np.sin(np.radians(dh) / 2)
    l_mean, cp_mean = (l1 + l2) / 2, (c1p + c2p) / 2
    h_sum = h1p + h2p
    h_mean = np.where(c1p * c2p == 0, h_sum,
                      np.where(np.abs(h1p - h2p) <= 180, h_sum / 2,
                               np.where(h_sum < 360, (h_sum + 360) / 2, (h_sum - 360) / 2)))
    t = (1 - 0.17 * np.cos(np.radians(h_mean - 30)) + 0.24 * np.cos(np.radians(2 * h_mean))
         + 0.32 * np.cos(np.radians(3 * h_mean + 6)) - 0.20 * np.cos(np.radians(4 * h_mean - 63)))
    sl = 1 + 0.015 * (l_mean - 50) ** 2 / np.sqrt(20 + (l_mean - 50) ** 2)
    sc, sh = 1 + 0.045 * cp_mean, 1 + 0.015 * cp_mean * t
    rt = (-2 * np.sqrt(cp_mean**7 / (cp_mean**7 + 25.0**7))
          * np.sin(np.radians(60 * np.exp(-(((h_mean - 275) / 25) ** 2)))))
    return np.sqrt((dl / sl) ** 2 + (dc / sc) ** 2 + (dhh / sh) ** 2 + rt * (dc / sc) * (dhh / sh))
