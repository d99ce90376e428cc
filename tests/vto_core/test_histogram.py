"""Tests for vto_core.histogram: masked inverse-CDF histogram matching LUTs."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from vto_core.colour import luminance
from vto_core.errors import VtoError
from vto_core.histogram import HistogramMatch, apply_lut, fit_histogram_match, limit_slope, match_lut

fast = settings(max_examples=60, deadline=None)
# Includes HDR and negative values, which are clipped to [0, 1] before matching.
wide_values = arrays(np.float64, st.integers(1, 64), elements=st.floats(-2.0, 5.0))
wide_images = arrays(
    np.float64, st.tuples(st.integers(1, 6), st.integers(1, 6), st.just(3)), elements=st.floats(-2.0, 5.0)
)


def rng(seed=0):
    return np.random.default_rng(seed)


def assert_monotone_in_unit_range(lut_y):
    assert np.all(np.diff(lut_y) >= 0.0)
    assert np.all((lut_y >= 0.0) & (lut_y <= 1.0))


def test_lut_x_is_linspace_and_outputs_are_float32():
    lut_x, lut_y = match_lut(rng().uniform(size=100), rng(1).uniform(size=100), n_points=17)
    np.testing.assert_array_equal(lut_x, np.linspace(0.0, 1.0, 17, dtype=np.float32))
    assert lut_x.dtype == np.float32 and lut_y.dtype == np.float32
    assert lut_y.shape == (17,)


def test_uniform_half_matched_to_upper_half_shifts_by_half():
    source = np.linspace(0.0, 0.5, 20001)
    reference = np.linspace(0.5, 1.0, 20001)
    lut_x, lut_y = match_lut(source, reference, n_points=65)
    on_support = lut_x <= 0.5
    np.testing.assert_allclose(lut_y[on_support], 0.5 + lut_x[on_support], atol=1e-3)
    # Above the source's support the CDF is 1: the reference maximum.
    np.testing.assert_allclose(lut_y[~on_support], 1.0, atol=1e-6)


def test_hand_computed_small_lut():
    # source {0.25, 0.75}: F(0) = 0, F(0.25) = 0.25, F(0.5) = 0.5, F(0.75) = 0.75, F(1) = 1.
    # reference {0.2, 0.4, 0.6}: linear quantile q(p) = 0.2 + 0.4 * p.
    lut_x, lut_y = match_lut([0.25, 0.75], [0.2, 0.4, 0.6], n_points=5)
    np.testing.assert_allclose(lut_x, [0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(lut_y, [0.2, 0.3, 0.4, 0.5, 0.6], atol=1e-7)


def test_sample_matched_to_itself_is_near_identity_on_its_support():
    sample = rng().beta(2.0, 3.0, size=20000)
    lut_x, lut_y = match_lut(sample, sample, n_points=64)
    lower, upper = np.quantile(sample, [0.01, 0.99])
    on_support = (lut_x >= lower) & (lut_x <= upper)
    assert on_support.sum() > 30
    np.testing.assert_allclose(lut_y[on_support], lut_x[on_support], atol=2e-3)


def test_values_are_clipped_before_matching():
    source = rng().uniform(-1.0, 2.0, size=500)
    reference = rng(1).uniform(-1.0, 2.0, size=500)
    np.testing.assert_array_equal(
        match_lut(source, reference)[1], match_lut(np.clip(source, 0, 1), np.clip(reference, 0, 1))[1]
    )


@fast
@given(wide_values, wide_values, st.integers(2, 80))
def test_lut_is_monotone_and_in_unit_range(source, reference, n_points):
    lut_x, lut_y = match_lut(source, reference, n_points=n_points)
    assert lut_x.shape == lut_y.shape == (n_points,)
    assert_monotone_in_unit_range(lut_y)


def test_empty_source_gives_identity_and_warns():
    with pytest.warns(UserWarning, match="mask is empty"):
        lut_x, lut_y = match_lut(np.array([]), rng().uniform(size=10), n_points=9)
    np.testing.assert_array_equal(lut_y, lut_x)


def test_empty_reference_raises():
    with pytest.raises(VtoError, match="reference"):
        match_lut(rng().uniform(size=10), np.array([]))


def test_constant_source_gives_reference_median():
    reference = np.array([0.1, 0.2, 0.7, 0.9, 0.95])
    _, lut_y = match_lut(np.full(50, 0.4), reference, n_points=8)
    np.testing.assert_allclose(lut_y, 0.7, atol=1e-7)


def test_constant_reference_gives_that_constant():
    _, lut_y = match_lut(rng().uniform(size=200), np.full(30, 0.35), n_points=8)
    np.testing.assert_allclose(lut_y, 0.35, atol=1e-7)


@pytest.mark.parametrize("bad_value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("bad_input", ["source_values", "reference_values"])
def test_non_finite_values_raise_naming_the_input(bad_input, bad_value):
    inputs = dict(source_values=rng().uniform(size=20), reference_values=rng(1).uniform(size=20))
    inputs[bad_input][5] = bad_value
    with pytest.raises(VtoError, match=bad_input):
        match_lut(**inputs)


@pytest.mark.parametrize("n_points", [1, 0, -3, 2.5])
def test_n_points_below_two_raises(n_points):
    with pytest.raises(VtoError, match="n_points"):
        match_lut([0.1, 0.5], [0.2, 0.3], n_points=n_points)
    with pytest.raises(VtoError, match="n_points"):
        fit_histogram_match(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)), n_points=n_points)


def test_apply_lut_interpolates_after_clipping():
    lut_x, lut_y = np.array([0.0, 0.5, 1.0]), np.array([0.2, 0.4, 1.0])
    values = np.array([[-1.0, 0.0, 0.25], [0.75, 1.0, 7.0]])
    out = apply_lut(values, lut_x, lut_y)
    assert out.dtype == np.float32 and out.shape == (2, 3)
    np.testing.assert_allclose(out, [[0.2, 0.2, 0.3], [0.7, 1.0, 1.0]], atol=1e-7)


def test_histogram_match_applies_channel_luts_before_gray_lut():
    lut_x = np.array([0.0, 1.0])
    halve = (lut_x, np.array([0.0, 0.5]))
    square_ish = (np.array([0.0, 0.5, 1.0]), np.array([0.0, 0.1, 1.0]))
    match = HistogramMatch(gray_lut=halve, channel_luts=(square_ish, halve, (lut_x, lut_x)))
    out = match.apply(np.array([1.0, 1.0, 1.0]))
    # channels first (Blender's RGB Curves: R, G, B, then C): R 1 -> 1, G 1 -> 0.5, B 1 -> 1; then gray halves.
    # The opposite order would give R = 0.1, G = 0.25, B = 0.5.
    np.testing.assert_allclose(out, [0.5, 0.25, 0.5], atol=1e-7)


def make_image_pair(seed=0):
    generator = rng(seed)
    source = generator.beta(2.0, 4.0, size=(64, 64, 3)) * np.array([1.0, 0.9, 0.8])
    reference = generator.beta(4.0, 2.0, size=(48, 48, 3)) * np.array([0.8, 0.9, 1.0])
    return source, reference


def test_fit_then_apply_matches_reference_quantiles():
    source, reference = make_image_pair()
    source_mask = np.zeros((64, 64), bool)
    source_mask[8:56, 8:56] = True
    reference_mask = np.zeros((48, 48))
    reference_mask[:, 10:40] = 1.0
    match = fit_histogram_match(source, reference, source_mask, reference_mask)
    matched = match.apply(source)[source_mask]
    reference_inside = reference[reference_mask > 0.5]
    probabilities = np.linspace(0.05, 0.95, 19)
    # The gray LUT is applied last, so gray matches closely and channels stay near their match.
    np.testing.assert_allclose(
        np.quantile(luminance(matched), probabilities), np.quantile(luminance(reference_inside), probabilities), atol=0.02
    )
    for channel in range(3):
        np.testing.assert_allclose(
            np.quantile(matched[:, channel], probabilities),
            np.quantile(reference_inside[:, channel], probabilities),
            atol=0.08,
        )
    # Unmatched, the source is far from the reference, so the check above can fail.
    assert abs(np.median(source[source_mask]) - np.median(reference_inside)) > 0.2


def test_fit_luts_are_monotone_and_gray_lut_matches_luminance():
    source, reference = make_image_pair(1)
    match = fit_histogram_match(source, reference, n_points=32)
    channel_mapped = np.stack([apply_lut(source[..., c], *match.channel_luts[c]) for c in range(3)], -1)
    expected_gray = match_lut(luminance(channel_mapped), luminance(reference), n_points=32)
    np.testing.assert_array_equal(match.gray_lut[1], expected_gray[1])
    assert len(match.channel_luts) == 3
    for lut_x, lut_y in (match.gray_lut, *match.channel_luts):
        assert lut_x.shape == lut_y.shape == (32,)
        assert_monotone_in_unit_range(lut_y)


@fast
@given(wide_images, wide_images)
def test_fit_luts_are_monotone_for_any_images(source, reference):
    match = fit_histogram_match(source, reference, n_points=16)
    for _, lut_y in (match.gray_lut, *match.channel_luts):
        assert_monotone_in_unit_range(lut_y)
    out = match.apply(source)
    assert np.all((out >= 0.0) & (out <= 1.0))


def test_pixels_outside_masks_do_not_influence_the_luts():
    source, reference = make_image_pair(2)
    source_mask = rng(3).uniform(size=(64, 64)) > 0.4
    reference_mask = rng(4).uniform(size=(48, 48)) > 0.6
    before = fit_histogram_match(source, reference, source_mask, reference_mask)
    changed_source, changed_reference = source.copy(), reference.copy()
    changed_source[~source_mask] = rng(5).uniform(-1.0, 3.0, size=changed_source[~source_mask].shape)
    changed_reference[~reference_mask] = np.nan
    after = fit_histogram_match(changed_source, changed_reference, source_mask, reference_mask)
    luts_before = (before.gray_lut, *before.channel_luts)
    luts_after = (after.gray_lut, *after.channel_luts)
    for lut_before, lut_after in zip(luts_before, luts_after):
        np.testing.assert_array_equal(lut_before[1], lut_after[1])
    # Without the mask the changed pixels do matter, so the comparison above can fail.
    unmasked = fit_histogram_match(changed_source, reference, None, reference_mask)
    assert not np.array_equal(unmasked.gray_lut[1], before.gray_lut[1])


def test_empty_source_mask_gives_identity_luts_and_exactly_one_warning():
    source, reference = make_image_pair()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        match = fit_histogram_match(source, reference, np.zeros((64, 64), bool), n_points=10)
    assert len(caught) == 1
    assert "mask is empty" in str(caught[0].message)
    for lut_x, lut_y in (match.gray_lut, *match.channel_luts):
        np.testing.assert_array_equal(lut_y, lut_x)
    np.testing.assert_allclose(match.apply(source), source, atol=1e-6)


def test_empty_reference_mask_raises():
    source, reference = make_image_pair()
    with pytest.raises(VtoError, match="reference"):
        fit_histogram_match(source, reference, None, np.zeros((48, 48)))


def test_constant_source_image_maps_to_reference_channel_medians():
    _, reference = make_image_pair()
    match = fit_histogram_match(np.full((8, 8, 3), 0.3), reference)
    out = match.apply(np.full((2, 2, 3), 0.3))
    np.testing.assert_allclose(out[0, 0], np.median(reference.reshape(-1, 3), axis=0), atol=1e-6)


@pytest.mark.parametrize(
    "source_mask_shape, reference_mask_shape",
    [((64, 63), None), ((64, 64, 1), None), (None, (48,)), (None, (47, 48))],
)
def test_mask_shape_mismatch_raises(source_mask_shape, reference_mask_shape):
    source, reference = make_image_pair()
    source_mask = None if source_mask_shape is None else np.ones(source_mask_shape, bool)
    reference_mask = None if reference_mask_shape is None else np.ones(reference_mask_shape, bool)
    with pytest.raises(VtoError, match="mask"):
        fit_histogram_match(source, reference, source_mask, reference_mask)


def test_image_without_three_channels_raises():
    with pytest.raises(VtoError, match="source_rgb"):
        fit_histogram_match(np.zeros((4, 4, 4)), np.zeros((4, 4, 3)))


@pytest.mark.parametrize("bad_input", ["source", "reference"])
def test_non_finite_pixels_inside_mask_raise(bad_input):
    source, reference = make_image_pair()
    images = dict(source=source, reference=reference)
    images[bad_input][3, 4, 0] = np.inf
    with pytest.raises(VtoError, match=bad_input):
        fit_histogram_match(images["source"], images["reference"])


def test_limit_slope_caps_steps_and_keeps_the_mapped_mean():
    lut_x = np.linspace(0.0, 1.0, 11)
    lut_y = np.array([0.1, 0.12, 0.14, 0.16, 0.18, 0.2, 0.22, 0.24, 0.26, 0.9, 0.95])  # one step of slope 6.4
    source = rng().uniform(0.0, 1.0, 5000)
    capped = limit_slope(lut_x, lut_y, source, 2.0)
    assert capped.dtype == np.float32
    assert np.diff(capped).max() <= 2.0 * 0.1 + 1e-6
    assert np.diff(capped)[8] == pytest.approx(0.2, abs=1e-6)  # the steep step is cut to the cap
    assert np.diff(capped)[:8] == pytest.approx(np.diff(lut_y)[:8], abs=1e-6)  # gentle steps are kept
    mapped_mean = np.mean(np.interp(source, lut_x, lut_y))
    assert np.mean(np.interp(source, lut_x, capped)) == pytest.approx(mapped_mean, abs=1e-5)
    assert np.max(np.abs(capped - lut_y)) > 0.1  # the cap did change the curve, so the checks above can fail


def test_limit_slope_leaves_a_gentle_lut_alone_and_stays_in_range():
    lut_x = np.linspace(0.0, 1.0, 9)
    gentle = np.sqrt(lut_x) * 0.5 + 0.2
    source = rng(1).uniform(0.3, 1.0, 300)
    np.testing.assert_allclose(limit_slope(lut_x, gentle, source, 100.0), gentle, atol=1e-6)
    # A step LUT near the top: capping then shifting up must still clip into [0, 1] and stay monotone.
    step = np.where(lut_x < 0.5, 0.0, 1.0)
    assert_monotone_in_unit_range(limit_slope(lut_x, step, np.full(10, 0.9), 1.0))
    assert_monotone_in_unit_range(limit_slope(lut_x, step, np.array([]), 1.0))
    with pytest.raises(VtoError, match="max_slope"):
        limit_slope(lut_x, gentle, source, 0.0)


def test_fit_with_max_slope_caps_every_channel_lut():
    source, reference = make_image_pair(3)
    reference[:4] = 1.0  # a sparse bright tail in the reference makes the top of each LUT steep
    free = fit_histogram_match(source, reference, n_points=32, match_gray=False)
    capped = fit_histogram_match(source, reference, n_points=32, match_gray=False, max_slope=3.0)
    steepest = [np.max(np.diff(lut_y) / np.diff(lut_x)) for lut_x, lut_y in free.channel_luts]
    assert max(steepest) > 3.0
    for lut_x, lut_y in capped.channel_luts:
        assert np.max(np.diff(lut_y) / np.diff(lut_x)) <= 3.0 + 1e-3
        assert_monotone_in_unit_range(lut_y)
    np.testing.assert_array_equal(capped.gray_lut[1], capped.gray_lut[0])  # match_gray=False: identity gray
