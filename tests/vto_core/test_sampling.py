"""Sampler: determinism per (seed, index), range coverage, the fit on presets, the exact truncated normal."""

import numpy as np
import pytest
from scipy.stats import truncnorm

from vto_core.errors import VtoError
from vto_core.presets import load_presets, preset_matrix
from vto_core.sampling import ParamSampler, PresetKernels, PresetNormal, at_lightness, truncated_standard_normal
from vto_core.products import get_spec, product_names


def make(renderer, ratio=0.5, seed=0, params=None):
    spec = get_spec(renderer, params)
    return ParamSampler(spec, preset_matrix(spec, load_presets(renderer)), ratio, seed)


def test_presets_meet_the_minimum_counts_and_ranges():
    lip, hair = load_presets("lipstick"), load_presets("hair")
    assert len(lip) >= 30 and len(hair) >= 20
    for renderer, presets in (("lipstick", lip), ("hair", hair)):
        spec = get_spec(renderer)
        for values in presets.values():
            for name, value in values.items():
                p = spec.by_name[name]
                assert p.low <= value <= p.high, (renderer, name, value)
    dark = [v for v in lip.values() if max(v["red"], v["green"], v["blue"]) < 60]
    assert len(dark) >= 3, "the paper's user study failed on very dark shades: keep several"


def test_sample_i_does_not_depend_on_what_was_drawn_before():
    a, b = make("lipstick", seed=7), make("lipstick", seed=7)
    forward = [a.sample(i) for i in range(20)]
    backward = [b.sample(i) for i in reversed(range(20))][::-1]
    assert np.array_equal(np.stack(forward), np.stack(backward))
    assert not np.array_equal(make("lipstick", seed=8).sample(3), forward[3])


def test_samples_stay_in_range_and_cover_it():
    for renderer in product_names():
        sampler = make(renderer, ratio=0.5)
        unit = np.stack([sampler.sample_unit(i) for i in range(600)])
        assert unit.min() >= 0.0 and unit.max() <= 1.0
        raw = np.stack([sampler.sample(i) for i in range(600)])
        assert np.isfinite(raw).all()
        # uniform half reaches both ends of every dimension
        assert (unit.min(0) < 0.05).all() and (unit.max(0) > 0.95).all()


def test_uniform_ratio_one_is_uniform():
    sampler = make("hair", ratio=1.0)
    unit = np.stack([sampler.sample_unit(i) for i in range(2000)])
    assert np.allclose(unit.mean(0), 0.5, atol=0.03)
    assert np.allclose(unit.std(0), np.sqrt(1 / 12), atol=0.02)


def test_preset_only_sampling_follows_the_fit():
    spec = get_spec("lipstick", "opacity,red,green,blue,gloss_roughness")
    presets = preset_matrix(spec, load_presets("lipstick"))
    sampler = ParamSampler(spec, presets, uniform_ratio=0.0, seed=1)
    assert np.allclose(sampler.normal.mean, presets.mean(0), atol=1e-6)
    chol = sampler.normal.cholesky
    assert np.allclose(chol @ chol.T, np.cov(presets, rowvar=False) + 1e-4 * np.eye(5), atol=1e-6)
    unit = np.stack([sampler.sample_unit(i) for i in range(3000)])
    # The exact truncated normal, by brute-force rejection: means and the red-green correlation must match it.
    normal = sampler.normal
    raw = normal.mean + np.random.default_rng(0).standard_normal((200_000, 5)) @ normal.cholesky.T
    kept = raw[((raw >= 0) & (raw <= 1)).all(axis=1)]
    assert np.allclose(unit.mean(0), kept.mean(0), atol=0.015)
    corr_fit = np.corrcoef(unit[:, 1], unit[:, 2])[0, 1]
    assert abs(corr_fit - np.corrcoef(kept[:, 1], kept[:, 2])[0, 1]) < 0.05
    assert np.corrcoef(presets[:, 1], presets[:, 2])[0, 1] > 0.5 and corr_fit > 0.35  # weakened, not erased


def test_wrapping_hue_is_fitted_on_the_circle():
    spec = get_spec("hair", "hue")
    presets = np.array([[0.97], [0.99], [0.01], [0.03]])
    normal = PresetNormal.fit(spec, presets)
    draws = np.stack([normal.draw(np.random.default_rng(i)) for i in range(500)])
    near_zero = np.minimum(draws, 1 - draws)
    assert np.median(near_zero) < 0.05, "a naive mean would put the hue near 0.5"


def test_resample_one_changes_only_element_j():
    sampler = make("lipstick", seed=3, params="red,green,gloss")
    base = sampler.sample_unit(5)
    for j in range(3):
        moved = sampler.resample_one_unit(5, j)
        changed = np.nonzero(moved != base)[0].tolist()
        assert changed == [j]
        assert np.array_equal(moved, sampler.resample_one_unit(5, j))
    with pytest.raises(VtoError):
        sampler.resample_one_unit(5, 3)


def test_bad_arguments():
    spec = get_spec("hair")
    with pytest.raises(VtoError, match="uniform_ratio"):
        ParamSampler(spec, None, 1.5)
    with pytest.raises(VtoError, match="needs presets"):
        ParamSampler(spec, None, 0.5)
    with pytest.raises(VtoError, match="index"):
        make("hair").sample(-1)
    with pytest.raises(VtoError, match="at least 2 presets"):
        PresetNormal.fit(spec, np.zeros((1, 9)))
    with pytest.raises(VtoError, match="kernel's width"):
        ParamSampler(spec, None, 1.0, kernel=-0.1)
    with pytest.raises(VtoError, match="uniform lightness moves a modelled colour"):
        ParamSampler(get_spec("lipstick", "opacity,red,gloss"), None, 1.0, uniform_lightness=True)
    presets = preset_matrix(get_spec("lipstick"), load_presets("lipstick"))
    with pytest.raises(VtoError, match="shimmer is not among"):
        ParamSampler(get_spec("lipstick"), presets, 0.5, uniform_params=("red", "shimmer"))
    with pytest.raises(VtoError, match=r"uniform_ratio must be in \(0, 1\)"):
        ParamSampler(get_spec("lipstick"), presets, 0.0, uniform_params=("red",))


def test_preset_kernels_keep_the_presets_dark_end_where_one_normal_moves_it_to_the_middle():
    """Lipstick: the kernel draws are as often near black as the presets are (19 % with L* < 20); one normal fitted
    on the same presets draws far fewer there."""
    from vto_core.colour import srgb_to_lab

    spec = get_spec("lipstick")
    presets = preset_matrix(spec, load_presets("lipstick"))
    colour = [spec.modelled.index(name) for name in ("red", "green", "blue")]

    def dark_share(units):
        return float(np.mean(srgb_to_lab(np.asarray(units)[:, colour].astype(np.float32))[:, 0] < 20))

    kernels = ParamSampler(spec, presets, 0.0, 3, kernel=0.03)
    normal = ParamSampler(spec, presets, 0.0, 3)
    drawn = np.array([kernels.sample_unit(i) for i in range(600)])
    assert ((0.0 <= drawn) & (drawn <= 1.0)).all()
    assert abs(dark_share(drawn) - dark_share(presets)) < 0.06
    assert dark_share([normal.sample_unit(i) for i in range(600)]) < 0.5 * dark_share(presets)


def test_uniform_lightness_spreads_the_colours_evenly_over_lightness_and_leaves_the_rest():
    """Eye shadow, all draws uniform: with uniform_lightness a tenth of the colours in each tenth of L* (the RGB cube
    gives 3 % below L* 20); every other parameter is the draw it was without it, and the normal share is untouched."""
    from vto_core.colour import srgb_to_lab

    spec = get_spec("eyeshadow")
    colour = [spec.modelled.index(name) for name in ("red", "green", "blue")]
    rest = [k for k in range(spec.size) if k not in colour]
    even, cube = (ParamSampler(spec, None, 1.0, 5, uniform_lightness=flag) for flag in (True, False))
    drawn, plain = (np.array([s.sample_unit(i) for i in range(2000)]) for s in (even, cube))
    lightness = srgb_to_lab(drawn[:, colour].astype(np.float32))[:, 0]
    assert ((0.0 <= drawn) & (drawn <= 1.0)).all()
    assert np.allclose(np.histogram(lightness, bins=10, range=(0, 100))[0] / 2000, 0.1, atol=0.025)
    assert np.mean(srgb_to_lab(plain[:, colour].astype(np.float32))[:, 0] < 20) < 0.05
    assert np.array_equal(drawn[:, rest], plain[:, rest])
    presets = preset_matrix(spec, load_presets("eyeshadow"))
    mixed, normal = (ParamSampler(spec, presets, 0.5, 5, uniform_lightness=flag) for flag in (True, False))
    same = [np.array_equal(mixed.sample_unit(i), normal.sample_unit(i)) for i in range(200)]
    assert 60 < sum(same) < 140  # the normal's half is the same draws; the uniform half moved


def test_uniform_params_spread_the_colour_and_take_the_finish_from_a_preset_draw():
    """Eye shadow, uniform_params = opacity and colour: the uniform half's colours are the draws they were without
    it, and its finish comes from the presets' kernels, so the mattes' zero sheen is as common there as among the
    presets (an even draw puts 5 % of the shimmers below 0.05); the preset half is untouched."""
    spec = get_spec("eyeshadow")
    presets = preset_matrix(spec, load_presets("eyeshadow"))
    spread = [spec.modelled.index(name) for name in ("opacity", "red", "green", "blue")]
    shimmer = spec.modelled.index("shimmer")
    finish, every = (ParamSampler(spec, presets, 1.0 - 1e-9, 5, kernel=0.01, uniform_params=chosen)
                     for chosen in (("opacity", "red", "green", "blue"), ()))
    drawn, plain = (np.array([s.sample_unit(i) for i in range(1000)]) for s in (finish, every))
    assert ((0.0 <= drawn) & (drawn <= 1.0)).all()
    assert np.array_equal(drawn[:, spread], plain[:, spread])
    matte_share = float(np.mean(presets[:, shimmer] == 0.0))
    assert abs(np.mean(drawn[:, shimmer] < 0.05) - matte_share) < 0.06
    assert np.mean(plain[:, shimmer] < 0.05) < 0.08
    mixed, normal = (ParamSampler(spec, presets, 0.5, 5, kernel=0.12, uniform_params=chosen)
                     for chosen in (("opacity", "red", "green", "blue"), ()))
    same = [np.array_equal(mixed.sample_unit(i), normal.sample_unit(i)) for i in range(200)]
    assert 60 < sum(same) < 140  # the kernels' half is the same draws; the uniform half's finish moved


@pytest.mark.parametrize("rgb", [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (0.9, 0.1, 0.2), (0.2, 0.5, 0.9)])
@pytest.mark.parametrize("lightness", [0.0, 4.0, 20.0, 60.0, 100.0])
def test_at_lightness_hits_the_lightness_and_keeps_the_hue_when_darkening(rgb, lightness):
    """At both ends (black, white, L* 0 and 100) the colour lands on the lightness asked; darkening keeps the linear
    chromaticity exactly (a scale), and every result is finite and in [0, 1]."""
    from vto_core.colour import srgb_to_lab, srgb_to_linear

    moved = at_lightness(np.array(rgb), lightness)
    assert np.isfinite(moved).all() and ((0.0 <= moved) & (moved <= 1.0)).all()
    assert abs(float(srgb_to_lab(moved.astype(np.float32))[0]) - lightness) < 0.05
    before, after = srgb_to_linear(np.array(rgb)), srgb_to_linear(moved)
    if 0 < lightness < float(srgb_to_lab(np.array(rgb, np.float32))[0]):
        assert np.allclose(after / after.sum(), before / before.sum(), atol=1e-4)


def test_preset_kernels_reflect_at_the_edges_and_wrap_hue():
    """A preset at 0 and 1 moved by a wide kernel stays in [0, 1] (reflected, not piled at the edge); hue wraps."""
    wraps = np.array([False, True])
    kernels = PresetKernels(np.array([[0.0, 0.99], [1.0, 0.01]]), 0.2, wraps)
    rng = np.random.default_rng(0)
    drawn = np.array([kernels.draw(rng) for _ in range(2000)])
    assert ((0.0 <= drawn) & (drawn < 1.0 + 1e-12)).all()
    assert np.mean(drawn[:, 0] == 0.0) < 0.01 and np.mean(drawn[:, 0] == 1.0) < 0.01
    assert np.mean((drawn[:, 1] < 0.2) | (drawn[:, 1] > 0.8)) > 0.6  # about 0 on the circle, not pulled to 0.5


def test_truncated_normal_is_a_truncated_normal_not_a_clipped_one():
    """2-D case against brute-force rejection: same mean and covariance, and no mass piled on the box faces."""
    spec = get_spec("lipstick", "red,green")
    normal = PresetNormal(np.array([0.85, 0.2]), np.linalg.cholesky(np.array([[0.04, 0.03], [0.03, 0.04]])),
                          np.array([False, False]))
    draws = np.stack([normal.draw(np.random.default_rng([1, i])) for i in range(3000)])
    rng = np.random.default_rng(2)
    raw = normal.mean + rng.standard_normal((200_000, 2)) @ normal.cholesky.T
    kept = raw[((raw >= 0) & (raw <= 1)).all(axis=1)][:20_000]
    assert np.allclose(draws.mean(0), kept.mean(0), atol=0.012)
    assert np.allclose(np.cov(draws.T), np.cov(kept.T), atol=0.004)
    assert ((draws == 0.0) | (draws == 1.0)).mean() == 0.0
    assert spec.size == 2


def test_full_lipstick_fit_needs_no_clipping_and_far_tails_stay_finite():
    spec = get_spec("lipstick", [p.name for p in get_spec("lipstick").params])
    normal = PresetNormal.fit(spec, preset_matrix(spec, load_presets("lipstick")))
    draws = np.stack([normal.draw(np.random.default_rng([3, i])) for i in range(200)])
    assert ((draws > 0) & (draws < 1)).all()  # strictly inside: no draw was clipped onto a face
    far = PresetNormal(np.array([14.0, -9.0]), np.eye(2) * 0.01, np.array([False, False]))  # 1,300 sigma out
    tail = np.stack([far.draw(np.random.default_rng(i)) for i in range(20)])
    assert np.isfinite(tail).all() and (tail >= 0).all() and (tail <= 1).all()
    assert tail[:, 0].min() > 0.99 and tail[:, 1].max() < 0.01


def test_truncated_standard_normal_is_scipys_inverse_cdf_even_1300_sigma_out():
    windows = [(-1, 2), (0.5, 0.6), (10, 11), (-12, -10), (40, np.inf), (-np.inf, -38), (1300, 1301), (-1301, -1300)]
    for low, high in windows:
        for u in (0.0, 0.1, 0.5, 0.9, 1 - 1e-16):
            got = truncated_standard_normal(u, low, high)
            assert np.isfinite(got) and low <= got <= high, (low, high, u, got)
            if 0 < u < 1:  # above zero the mirror's quantile u is used: the quantile 1 - u
                expected = truncnorm.ppf(u if low <= 0 else 1 - u, low, high)
                assert abs(got - expected) < 1e-9 * (1 + abs(expected)), (low, high, u, got, expected)
    for low, high in ((3.0, 3.0), (-1e-14, 1e-14), (2.0, 2.0 - 1e-15), (-np.inf, np.inf)):  # degenerate and open
        assert all(np.isfinite(truncated_standard_normal(u, low, high)) for u in (0.0, 0.5, 1 - 1e-16))


def test_far_tails_match_scipy_without_importing_it():
    """Beyond 37 sigma the log CDF and its inverse are pure Python (Blender's Python has no scipy)."""
    import subprocess
    import sys

    from scipy.special import log_ndtr, ndtri_exp

    from vto_core.sampling import _log_phi, _phi_inverse_of_log

    for x in -np.logspace(np.log10(37.0), 6, 60):
        assert abs(_log_phi(float(x)) - log_ndtr(x)) <= 1e-13 * abs(log_ndtr(x)), x
    for log_p in -np.logspace(np.log10(690.0), 12, 60):
        assert abs(_phi_inverse_of_log(float(log_p)) - ndtri_exp(log_p)) <= 1e-11 * abs(ndtri_exp(log_p)), log_p
    blocked = ("import sys; sys.modules['scipy'] = None\n"
               "from vto_core.sampling import truncated_standard_normal as t\n"
               "print(t(0.5, -1301, -1300), t(0.5, 1300, 1301))")
    done = subprocess.run([sys.executable, "-c", blocked], capture_output=True, text=True, check=True)
    low, high = map(float, done.stdout.split())
    assert -1301 <= low <= -1300 and 1300 <= high <= 1301


def test_one_dimensional_draws_follow_scipys_truncnorm():
    mean, sd = 0.9, 0.3  # truncation removes 37 % of the mass, most of it above 1
    normal = PresetNormal(np.array([mean]), np.array([[sd]]), np.array([False]))
    draws = np.array([normal.draw(np.random.default_rng([4, i]))[0] for i in range(4000)])
    exact = truncnorm((0 - mean) / sd, (1 - mean) / sd, loc=mean, scale=sd)
    assert abs(draws.mean() - exact.mean()) < 0.01 and abs(draws.var() - exact.var()) < 0.005
    assert abs(exact.mean() - mean) > 0.1  # the case is one where truncation matters
    ordered = np.sort(draws)
    ks = np.abs(exact.cdf(ordered) - np.arange(1, ordered.size + 1) / ordered.size).max()
    assert ks < 0.03, ks  # 99 % critical value at n = 4,000 is 0.026
    assert 0 < draws.min() and draws.max() < 1


def test_draw_is_a_pure_function_of_its_generator():
    spec = get_spec("hair")
    normal = PresetNormal.fit(spec, preset_matrix(spec, load_presets("hair")))
    first = [normal.draw(np.random.default_rng([6, i])) for i in range(5)]
    again = [normal.draw(np.random.default_rng([6, i])) for i in reversed(range(5))][::-1]
    assert np.array_equal(np.stack(first), np.stack(again))
    assert not np.allclose(first[0], first[1])


def test_hue_stays_on_the_circle_and_is_not_truncated():
    """Hue centred at 0.98 with sd 0.05: its draws wrap past 1 to small values instead of piling up at 1."""
    draws = {}
    for centre in (0.98, 2.98):  # a whole number of turns changes nothing
        normal = PresetNormal(np.array([centre, 0.5]), np.diag([0.05, 0.1]), np.array([True, False]))
        draws[centre] = np.stack([normal.draw(np.random.default_rng([5, i])) for i in range(3000)])
    hue = draws[0.98][:, 0]
    assert (hue >= 0).all() and (hue < 1).all()
    assert abs((hue < 0.5).mean() - 0.3446) < 0.03  # P(N(0.98, 0.05) > 1) = Phi(-0.4)
    offset = (hue - 0.98 + 0.5) % 1.0 - 0.5
    assert abs(offset.std() - 0.05) < 0.003 and abs(offset.mean()) < 0.004
    turned = (draws[2.98] - draws[0.98] + 0.5) % 1.0 - 0.5
    assert np.abs(turned).max() < 1e-9
