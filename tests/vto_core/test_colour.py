"""Tests for vto_core.colour: sRGB transfer, HSV and the swatch recolouring."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from vto_core.colour import (
    LUMA_WEIGHTS,
    hsv_to_rgb,
    linear_to_srgb,
    luminance,
    recolour_swatch,
    rgb_to_hsv,
    srgb_to_linear,
)
from vto_core.errors import VtoError

IDENTITY_PARAMS = dict(brightness=0.0, contrast=1.0, exposure=1.0, gamma=1.0, hue=0.0, saturation=1.0)
# Paper Table 3 ranges.
PARAM_RANGES = dict(
    brightness=(-0.3, 0.3),
    contrast=(0.5, 2.0),
    exposure=(0.5, 2.0),
    gamma=(0.5, 3.0),
    hue=(0.0, 1.0),
    saturation=(0.0, 3.0),
)

unit_floats = st.floats(0.0, 1.0, allow_nan=False, width=32)
unit_rgb_arrays = arrays(np.float32, st.tuples(st.integers(1, 16), st.just(3)), elements=unit_floats)
fast = settings(max_examples=60, deadline=None)


def test_srgb_to_linear_known_values():
    assert srgb_to_linear(0.5) == pytest.approx(0.21404114, abs=1e-7)
    assert srgb_to_linear(0.0) == 0.0
    assert srgb_to_linear(1.0) == pytest.approx(1.0, abs=1e-7)
    assert srgb_to_linear(0.02) == pytest.approx(0.02 / 12.92, rel=1e-6)


def test_linear_to_srgb_known_values():
    assert linear_to_srgb(0.18) == pytest.approx(0.4613561, abs=1e-6)
    assert linear_to_srgb(0.0) == 0.0
    assert linear_to_srgb(1.0) == pytest.approx(1.0, abs=1e-7)
    assert linear_to_srgb(0.001) == pytest.approx(0.01292, rel=1e-6)


def test_transfer_functions_are_continuous_at_their_breakpoints():
    just_below_decode = np.nextafter(0.04045, 0.0)
    assert srgb_to_linear(just_below_decode) == pytest.approx(srgb_to_linear(0.04045), abs=1e-7)
    just_below_encode = np.nextafter(0.0031308, 0.0)
    assert linear_to_srgb(just_below_encode) == pytest.approx(linear_to_srgb(0.0031308), abs=1e-6)


def test_negative_values_map_to_zero():
    negatives = np.array([-1e-6, -0.03, -0.5, -4.0, -1e30])
    np.testing.assert_array_equal(srgb_to_linear(negatives), 0.0)
    np.testing.assert_array_equal(linear_to_srgb(negatives), 0.0)


def test_hdr_values_extrapolate_with_the_power_law():
    assert srgb_to_linear(4.0) == pytest.approx((4.055 / 1.055) ** 2.4, rel=1e-6)
    assert linear_to_srgb(4.0) == pytest.approx(1.055 * 4.0 ** (1 / 2.4) - 0.055, rel=1e-6)
    huge = np.array([1e30, 1e300])
    assert np.all(np.isfinite(srgb_to_linear(huge)))
    assert np.all(np.isfinite(linear_to_srgb(huge)))


def test_transfer_outputs_are_float32_and_keep_shape():
    values = np.linspace(0.0, 1.0, 12).reshape(2, 2, 3)
    assert srgb_to_linear(values).dtype == np.float32
    assert linear_to_srgb(values).shape == (2, 2, 3)


@fast
@given(arrays(np.float64, st.integers(1, 32), elements=st.floats(0.0, 1.0)))
def test_srgb_linear_round_trip(srgb):
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(srgb)), srgb, atol=1e-5)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(srgb)), srgb, atol=1e-6)


def test_luminance_uses_rec709_weights():
    assert LUMA_WEIGHTS == (0.2126, 0.7152, 0.0722)
    np.testing.assert_allclose(luminance(np.eye(3)), LUMA_WEIGHTS, rtol=1e-6)
    gray = luminance(np.full((4, 5, 3), 0.25))
    assert gray.shape == (4, 5)
    np.testing.assert_allclose(gray, 0.25, rtol=1e-6)


def test_luminance_rejects_wrong_last_axis():
    with pytest.raises(VtoError):
        luminance(np.zeros((4, 2)))


@pytest.mark.parametrize(
    "rgb, hsv",
    [
        ((1.0, 0.0, 0.0), (0.0, 1.0, 1.0)),
        ((0.0, 1.0, 0.0), (1 / 3, 1.0, 1.0)),
        ((0.0, 0.0, 1.0), (2 / 3, 1.0, 1.0)),
        ((1.0, 1.0, 0.0), (1 / 6, 1.0, 1.0)),
        ((0.5, 0.5, 0.5), (0.0, 0.0, 0.5)),
        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ((0.5, 0.25, 0.5), (5 / 6, 0.5, 0.5)),
    ],
)
def test_known_hsv_values(rgb, hsv):
    np.testing.assert_allclose(rgb_to_hsv(rgb), hsv, atol=1e-6)
    np.testing.assert_allclose(hsv_to_rgb(hsv), rgb, atol=1e-6)


@fast
@given(unit_rgb_arrays)
def test_rgb_hsv_round_trip(rgb):
    hsv = rgb_to_hsv(rgb)
    assert np.all((hsv >= 0.0) & (hsv <= 1.0))
    assert np.all(hsv[..., 0] < 1.0)
    np.testing.assert_allclose(hsv_to_rgb(hsv), rgb, atol=1e-5)


@fast
@given(unit_floats, unit_floats)
def test_hsv_hue_one_equals_hue_zero(saturation, value):
    np.testing.assert_allclose(
        hsv_to_rgb((1.0, saturation, value)), hsv_to_rgb((0.0, saturation, value)), atol=1e-6
    )
    np.testing.assert_allclose(
        hsv_to_rgb((1.25, saturation, value)), hsv_to_rgb((0.25, saturation, value)), atol=1e-6
    )


def test_hsv_to_rgb_stays_linear_in_saturation_above_one():
    # Blender's formula: r = ((nr - 1) * s + 1) * v; at h = 0, nr = 1 and ng = nb = 0.
    np.testing.assert_allclose(hsv_to_rgb((0.0, 2.0, 0.5)), (0.5, -0.5, -0.5), atol=1e-7)


def recolour(rgb, **overrides):
    return recolour_swatch(rgb, **{**IDENTITY_PARAMS, **overrides})


@fast
@given(unit_rgb_arrays)
def test_recolour_identity_returns_input(rgb):
    out = recolour(rgb)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, rgb, atol=1e-6)


@fast
@given(unit_rgb_arrays, st.floats(0.0, 1.0))
def test_recolour_hue_wraps(rgb, hue):
    params = dict(brightness=0.1, contrast=1.3, exposure=0.9, gamma=1.7, saturation=1.4)
    np.testing.assert_allclose(
        recolour(rgb, hue=hue, **params), recolour(rgb, hue=hue + 1.0, **params), atol=1e-6
    )
    np.testing.assert_allclose(recolour(rgb, hue=1.0), recolour(rgb, hue=0.0), atol=1e-6)


RANDOM_IMAGE = np.random.default_rng(0).uniform(0.0, 1.0, size=(8, 8, 3))
TEST_IMAGES = {
    "random": RANDOM_IMAGE,
    "constant": np.full((4, 4, 3), 0.3),
    "black": np.zeros((4, 4, 3)),
    "white": np.ones((4, 4, 3)),
    "hdr_and_negative": np.array([[[4.0, -0.5, 0.2], [1e6, 1e6, 1e6], [-3.0, -3.0, -3.0]]]),
}


@pytest.mark.parametrize("image_name", sorted(TEST_IMAGES))
@pytest.mark.parametrize("param_value_index", [0, 1])
@pytest.mark.parametrize("param_name", sorted(PARAM_RANGES))
def test_recolour_parameter_range_ends_stay_in_unit_range(param_name, param_value_index, image_name):
    image = TEST_IMAGES[image_name]
    out = recolour(image, **{param_name: PARAM_RANGES[param_name][param_value_index]})
    assert out.shape == image.shape
    assert np.all(np.isfinite(out))
    assert np.all((out >= 0.0) & (out <= 1.0))


def test_recolour_all_extremes_at_once_stay_in_unit_range():
    for corner in np.ndindex(*(2,) * len(PARAM_RANGES)):
        params = {name: PARAM_RANGES[name][end] for name, end in zip(sorted(PARAM_RANGES), corner)}
        out = recolour_swatch(RANDOM_IMAGE, **params)
        assert np.all((out >= 0.0) & (out <= 1.0))


def test_recolour_saturation_zero_gives_gray():
    out = recolour(RANDOM_IMAGE, saturation=0.0, hue=0.3, gamma=2.0)
    np.testing.assert_array_equal(out[..., 0], out[..., 1])
    np.testing.assert_array_equal(out[..., 1], out[..., 2])
    # Gray at the value channel: max of the gamma-adjusted input.
    np.testing.assert_allclose(out[..., 0], RANDOM_IMAGE.max(axis=-1) ** 0.5, atol=1e-6)


def test_recolour_saturation_above_one_pushes_channels_apart():
    rgb = np.array([0.4, 0.5, 0.6])
    out = recolour(rgb, saturation=2.0)
    # hsv of (0.4, 0.5, 0.6): s = 1/3 -> 2/3, so min channel = v * (1 - 2/3) = 0.2.
    np.testing.assert_allclose(out, (0.2, 0.4, 0.6), atol=1e-6)


def test_recolour_does_not_clamp_scaled_saturation():
    # hsv of (0.3, 0.5, 0.6): s = 0.5 -> 1.5, 6h = 10/3; ng = 2/3, nr = 0, nb = 1.
    # g = ((2/3 - 1) * 1.5 + 1) * 0.6 = 0.3 and r = -0.3 -> clipped to 0; clamping s to 1 would give g = 0.4.
    out = recolour(np.array([0.3, 0.5, 0.6]), saturation=3.0)
    np.testing.assert_allclose(out, (0.0, 0.3, 0.6), atol=1e-6)


def test_recolour_hand_computed_pixel():
    out = recolour_swatch(
        np.array([0.2, 0.4, 0.6]),
        brightness=0.1,
        contrast=2.0,
        exposure=0.5,
        gamma=2.0,
        hue=0.5,
        saturation=0.5,
    )
    # 1. (x - 0.5) * 2 + 0.5 + 0.1 = (0.0, 0.4, 0.8); 2. * 0.5 = (0.0, 0.2, 0.4); 3. in range.
    # 4. ** (1 / 2) = (0, sqrt(0.2), sqrt(0.4)).
    # 5. v = sqrt(0.4), s = 1, h = (4 + (r - g) / (v - 0)) / 6 = (4 - 1/sqrt(2)) / 6.
    #    h + 0.5 mod 1 -> 6h = 1 - 1/sqrt(2); nr = 1, ng = 1 - 1/sqrt(2), nb = 0; s = 0.5.
    #    r = v; g = ((ng - 1) * 0.5 + 1) * v = (1 - sqrt(2)/4) * v; b = 0.5 * v.
    value = math.sqrt(0.4)
    expected = (value, (1.0 - math.sqrt(2.0) / 4.0) * value, 0.5 * value)
    np.testing.assert_allclose(out, expected, atol=1e-6)


@pytest.mark.parametrize("gamma", [0.0, -1.0])
def test_recolour_rejects_non_positive_gamma(gamma):
    with pytest.raises(VtoError, match="gamma"):
        recolour(RANDOM_IMAGE, gamma=gamma)


@pytest.mark.parametrize("bad_value", [np.nan, np.inf, -np.inf])
def test_recolour_rejects_non_finite_input(bad_value):
    image = RANDOM_IMAGE.copy()
    image[3, 2, 1] = bad_value
    with pytest.raises(VtoError):
        recolour(image)


def test_recolour_rejects_non_finite_parameter():
    with pytest.raises(VtoError, match="hue"):
        recolour(RANDOM_IMAGE, hue=np.nan)


def test_recolour_rejects_wrong_last_axis():
    with pytest.raises(VtoError):
        recolour(np.zeros((4, 4)))


# Sharma, Wu and Dalal (2005), "The CIEDE2000 colour-difference formula": test pairs 1, 7, 17 and 25.
SHARMA_PAIRS = [((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
                ((50.0, 0.0, 0.0), (50.0, -1.0, 2.0), 2.3669),
                ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
                ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644)]


@pytest.mark.parametrize("lab1, lab2, expected", SHARMA_PAIRS)
def test_ciede2000_matches_sharmas_reference_pairs(lab1, lab2, expected):
    from vto_core.colour import ciede2000

    assert ciede2000(np.array(lab1), np.array(lab2)) == pytest.approx(expected, abs=1e-4)
    assert ciede2000(np.array(lab2), np.array(lab1)) == pytest.approx(expected, abs=1e-4)


def test_srgb_to_lab_known_values_and_extremes():
    from vto_core.colour import srgb_to_lab

    lab = srgb_to_lab(np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [1.0, 0.0, 0.0], [0.5, 0.5, 0.5]]))
    np.testing.assert_allclose(lab[0], [0.0, 0.0, 0.0], atol=1e-3)
    np.testing.assert_allclose(lab[1], [100.0, 0.0, 0.0], atol=1e-2)
    np.testing.assert_allclose(lab[2], [53.24, 80.09, 67.20], atol=0.02)  # sRGB red, D65
    np.testing.assert_allclose(lab[3], [53.39, 0.0, 0.0], atol=0.02)
    hdr = srgb_to_lab(np.array([[np.nan, np.inf, -np.inf], [1e30, 2.0, 0.5]]))
    assert np.isfinite(hdr).all()


def test_srgb_to_lab_in_float32_matches_float64():
    """fast: float32 input converts in float32 within 1e-4 of float64 (and only with it); HDR and non-finite float32
    stay finite."""
    from vto_core.colour import LAB_FLOAT32_LIMIT, srgb_to_lab

    values = np.random.default_rng(0).random((64, 64, 3))
    fast, exact = srgb_to_lab(values.astype(np.float32), fast=True), srgb_to_lab(values.astype(np.float32) * 1.0)
    # without `fast`, float32 input converts as the same values in float64 do, bit for bit
    assert fast.dtype == np.float32 and np.array_equal(exact, srgb_to_lab(values.astype(np.float32).astype(np.float64)))
    np.testing.assert_allclose(fast, exact, atol=1e-4)
    assert np.abs(fast - exact).max() > 0  # the float32 arithmetic was taken
    hdr = np.array([[np.nan, np.inf, -np.inf], [1e30, 2 * LAB_FLOAT32_LIMIT, 0.5], [-5.0, LAB_FLOAT32_LIMIT, 0.0]],
                   np.float32)
    assert np.isfinite(srgb_to_lab(hdr, fast=True)).all()
    np.testing.assert_allclose(srgb_to_lab(hdr[2:], fast=True), srgb_to_lab(hdr[2:]), rtol=1e-5)


@pytest.mark.parametrize("lightness", [0.0, 5.0, 8.0, 8.5, 50.0, 100.0])
def test_lightness_luminance_inverts_the_lightness_of_srgb_to_lab(lightness):
    """A grey of the luminance asked for reads that L* back (both sides of the CIE toe at L* 8); its relative luminance
    is its linear value."""
    from vto_core.colour import lightness_luminance, relative_luminance, srgb_to_lab

    y = lightness_luminance(lightness)
    grey = np.full(3, y)
    assert relative_luminance(grey) == pytest.approx(y, rel=1e-6, abs=1e-12)
    assert float(srgb_to_lab(linear_to_srgb(grey))[0]) == pytest.approx(lightness, abs=0.02)
