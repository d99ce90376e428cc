"""Numpy reference of the hair stage: gradient, shine, faded look, curves as Blender tabulates them."""

import warnings

import numpy as np
import pytest

from vto_core.errors import VtoError
from vto_core.hair import (CURVE_TABLE_POINTS, MAX_LUT_SLOPE, apply_curves_node, apply_hair_stage, blend_weight,
                           blur_radius, fit_hair_match, gaussian_blur, hair_gradient, render_hair_reference, shine)
from vto_core.histogram import HistogramMatch
from vto_core.products import get_spec

IDENTITY = (np.linspace(0, 1, 5), np.linspace(0, 1, 5))


def test_gradient_runs_from_the_top_to_the_bottom_of_the_hair():
    mask = np.zeros((6, 3))
    mask[1:5, 1] = 1
    t = hair_gradient(mask)
    assert t[:, 0].tolist() == pytest.approx([0, 0, 1 / 3, 2 / 3, 1, 1])
    assert np.array_equal(t[:, 0], t[:, 2])
    assert not hair_gradient(np.zeros((4, 4))).any()


def test_shine_keeps_ends_and_boosts_contrast():
    y = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    assert shine(y, 0.0) == pytest.approx(y)
    boosted = shine(y, 1.0)
    assert boosted == pytest.approx([0, 0.0625, 0.5, 0.9375, 1])  # y + 2 (smoothstep(y) - y)
    assert np.isfinite(shine(np.array([-3.0, 7.0, np.float32(3e38)]), 1.0)).all()


def test_shine_adds_local_contrast_around_the_blur():
    y = np.full((9, 9, 3), 0.5, np.float32)
    y[4, 4] = 0.7  # a highlight on a flat strand
    blurred = gaussian_blur(y, 2)
    out = shine(y, 1.0, blurred)
    assert out[4, 4, 0] > shine(y, 1.0)[4, 4, 0] > 0.7  # the local term lifts the highlight further
    assert out[0, 0] == pytest.approx(shine(y, 1.0)[0, 0])  # flat areas: the global curve only
    assert shine(y, 0.0, blurred) == pytest.approx(y)


def test_gaussian_blur_is_the_compositor_kernel():
    """Blender's Gaussian Blur of radius r: sigma r/3, weights to |i| <= r, edges extended (measured on an impulse)."""
    impulse = np.zeros((9, 9, 1), np.float32)
    impulse[4, 4] = 1.0
    blurred = gaussian_blur(impulse, 3)[4, 1:8, 0]
    assert blurred == pytest.approx([0.00177, 0.02155, 0.09658, 0.15924, 0.09658, 0.02155, 0.00177], abs=2e-5)
    assert gaussian_blur(np.ones((5, 7, 3)), 3) == pytest.approx(np.ones((5, 7, 3)))  # extended, not zero, edges
    assert blur_radius(64) == 3 and blur_radius(8) == 1


def test_blend_weight_moves_over_the_whole_range():
    t = np.linspace(0, 1, 5)
    assert blend_weight(t, -1.0) == pytest.approx(np.ones(5))
    assert blend_weight(t, 1.0) == pytest.approx(np.zeros(5))
    assert blend_weight(t, 0.0) == pytest.approx([0, 0, 0.5, 1, 1])
    coloured = [blend_weight(np.linspace(0, 1, 101), b).mean() for b in np.linspace(-1, 1, 21)]
    assert np.all(np.diff(coloured) < 0), "every step of blend must colour less hair"


def test_curves_node_equals_the_exact_composition_for_gentle_curves():
    gray = (np.linspace(0, 1, 3), np.array([0.0, 0.6, 1.0]))
    match = HistogramMatch(gray, (IDENTITY, IDENTITY, IDENTITY))
    rgb = np.random.default_rng(0).random((8, 8, 3))
    assert np.abs(apply_curves_node(rgb, match) - match.apply(rgb)).max() < 1e-6


def test_curves_node_tabulates_the_folded_curve_like_blender():
    # R halves, then a step in C between 0.25 and 0.25 + 1/1000: exact composition jumps, Blender's table does not
    step = (np.array([0.0, 0.25, 0.251, 1.0]), np.array([0.0, 0.0, 1.0, 1.0]))
    halve = (np.array([0.0, 1.0]), np.array([0.0, 0.5]))
    match = HistogramMatch(step, (halve, IDENTITY, IDENTITY))
    x = np.array([[[0.5022, 0.0, 0.0]]])
    exact, node = match.apply(x)[0, 0, 0], apply_curves_node(x, match)[0, 0, 0]
    t = np.linspace(0, 1, CURVE_TABLE_POINTS)
    folded = np.interp(np.interp(t, *halve), t, np.interp(t, *step))
    assert node == pytest.approx(np.interp(0.5022, t, folded))
    assert exact == pytest.approx(1.0) and node < 0.9


def test_stage_leaves_pixels_outside_the_mask_and_checks_shapes():
    rng = np.random.default_rng(1)
    source, swatch = rng.random((16, 16, 3)).astype(np.float32), rng.random((8, 8, 3))
    mask = np.zeros((16, 16), np.float32)
    mask[4:12, 4:12] = 1
    values = get_spec("hair").full_values({"hue": 0.5, "saturation": 2.0})
    out = render_hair_reference(source, mask, swatch, values)
    assert np.array_equal(out[mask == 0], source[mask == 0])
    assert np.abs(out[mask == 1] - source[mask == 1]).mean() > 0.01
    with pytest.raises(VtoError, match="differ in size"):
        apply_hair_stage(source, mask[:8], hair_gradient(mask), None, values)


def _hair_scene(seed=2, size=24):
    """A small synthetic source: brownish noisy hair in the top two thirds (mask), a grey backdrop, a swatch."""
    generator = np.random.default_rng(seed)
    source = np.clip(generator.normal([0.35, 0.25, 0.15], 0.08, (size, size, 3)), 0, 1).astype(np.float32)
    mask = np.zeros((size, size), np.float32)
    mask[2: 2 * size // 3, 4:-4] = 1
    source[mask == 0] = 0.5
    swatch = np.clip(generator.normal([0.2, 0.13, 0.07], 0.1, (16, 16, 3)), 0, 1)
    return source, mask, swatch


def test_reference_blend_colours_less_hair_at_every_step_of_its_range():
    source, mask, swatch = _hair_scene()
    hair = mask > 0.5
    change = [np.abs(render_hair_reference(source, mask, swatch, get_spec("hair").full_values(
        {"blend": b, "hue": 0.5})) - source)[hair].mean() for b in np.linspace(-1, 1, 11)]
    assert np.all(np.diff(change) < -1e-3), np.round(change, 4)
    assert change[-1] == 0.0 and change[0] > 0.05


def test_reference_hue_wraps():
    source, mask, swatch = _hair_scene()
    spec = get_spec("hair")
    low, high, half = (render_hair_reference(source, mask, swatch, spec.full_values({"hue": h, "saturation": 2.0}))
                       for h in (0.001, 0.999, 0.5))
    assert np.abs(low - high).max() < 3 / 255
    assert np.abs(low - half).max() > 50 / 255


def test_hair_match_slopes_are_capped():
    source, mask, swatch = _hair_scene()
    swatch[:1] = 1.0  # a few specular pixels: a sparse bright tail the uncapped match would stretch noise over
    match = fit_hair_match(source, mask, swatch)
    for lut_x, lut_y in match.channel_luts:
        assert np.max(np.diff(lut_y) / np.diff(lut_x)) <= MAX_LUT_SLOPE + 1e-3
        assert np.all(np.diff(lut_y) >= 0)


EXTREME_LOOKS = [{p.name: getattr(p, end)} for p in get_spec("hair").params for end in ("low", "high")] + [
    {p.name: p.low for p in get_spec("hair").params}, {p.name: p.high for p in get_spec("hair").params}]


@pytest.mark.parametrize("case", ["noisy", "empty mask", "constant", "hdr", "black", "white"])
def test_every_range_end_stays_finite_on_awkward_inputs(case):
    source, mask, swatch = _hair_scene()
    if case == "empty mask":
        mask[:] = 0
    elif case == "constant":
        source[:] = 0.4
    elif case == "hdr":
        source = source * 40.0  # scene-referred values far above display white
    elif case in ("black", "white"):
        source[:] = 0.0 if case == "black" else 1.0
        swatch[:] = 0.0 if case == "black" else 1.0
    spec = get_spec("hair")
    for look in EXTREME_LOOKS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the empty mask warns once per fit
            out = render_hair_reference(source, mask, swatch, spec.full_values(look))
        assert out.shape == source.shape and np.isfinite(out).all(), look
        assert out.min() >= 0.0 and out.max() <= 1.0, look
        outside = mask < 0.5
        assert np.array_equal(out[outside], np.clip(source, 0, 1)[outside]), look


def test_non_finite_source_is_refused():
    source, mask, swatch = _hair_scene()
    source[0, 0, 1] = np.nan  # outside the hair, but the whole image goes through the stage
    with pytest.raises(VtoError, match="NaN or inf"):
        render_hair_reference(source, mask, swatch, get_spec("hair").full_values({}))


def test_hair_square_finds_the_largest_square_of_hair_nearest_the_centre():
    from vto_core.hair import hair_square

    mask = np.zeros((40, 60))
    mask[5:35, 10:50] = 1.0  # a 30 x 40 block: the largest square is 30, centred in x
    assert hair_square(mask, 1.0) == (15, 5, 30)
    mask[20, 30] = 0.0  # one hole: at share 1 the square must avoid it, at 0.98 it may not
    x, y, side = hair_square(mask, 1.0)
    assert side < 30 and mask[y:y + side, x:x + side].all()
    assert hair_square(mask, 0.98)[2] == 30


def test_hair_square_is_none_for_thin_or_empty_masks():
    from vto_core.hair import hair_square

    assert hair_square(np.zeros((20, 20))) is None
    thin = np.zeros((20, 20))
    thin[:, 5:9] = 1.0  # 4 px wide: no 8 px square
    assert hair_square(thin) is None
    assert hair_square(np.ones((20, 20)), smallest=0.5) == (0, 0, 20)
    assert hair_square(np.full((10, 10), np.nan)) is None


def test_hair_square_finds_the_largest_square_a_side_by_side_search_finds():
    from vto_core.hair import hair_square

    def slow(mask, share):  # every side from the largest down, as hair_square did before it bisected
        table = np.zeros((mask.shape[0] + 1, mask.shape[1] + 1))
        table[1:, 1:] = mask.cumsum(0).cumsum(1)
        for side in range(min(mask.shape), 7, -1):
            inside = table[side:, side:] - table[:-side, side:] - table[side:, :-side] + table[:-side, :-side]
            if (inside >= share * side * side).any():
                return side
        return None

    rng = np.random.default_rng(3)
    for _ in range(25):
        mask = np.zeros((rng.integers(20, 90), rng.integers(20, 90)), bool)
        for _ in range(rng.integers(1, 4)):  # a few blobs of hair, with holes
            y, x = rng.integers(0, mask.shape[0]), rng.integers(0, mask.shape[1])
            mask[y:y + rng.integers(5, 60), x:x + rng.integers(5, 60)] = True
        mask &= rng.random(mask.shape) > 0.03
        for share in (1.0, 0.95):
            found = hair_square(mask, share)
            assert (found[2] if found else None) == slow(mask, share)
