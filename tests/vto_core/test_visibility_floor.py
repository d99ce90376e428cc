"""How precisely a render pins its parameters: seed differences, split-half information, the posterior floor."""

import numpy as np
import pytest

from vto_core.colour import linear_to_srgb, srgb_to_linear
from vto_core.visibility import (camera_jacobian, masked_block_means, noise_variance, parameter_floor,
                                 render_information, seed_differences)

SLOPES = np.array([[0.2, 0.0, 0.1], [0.0, 0.05, 0.3]])  # (P=2, C=3): how the image's colour moves with each unit
SIGMA = 0.02


def noisy_render(unit, seed):
    """A 16x16 image linear in two parameters whose noise changes with the parameters as well as with the seed
    (as a changed material makes Cycles sample other paths)."""
    key = int(1e6 * float(np.sum(unit))) % 2**31
    noise = np.random.default_rng([seed, key]).normal(0.0, SIGMA, (16, 16, 3))
    return np.broadcast_to(0.3 + np.asarray(unit) @ SLOPES, (16, 16, 3)) + noise


def test_split_half_information_matches_the_truth_where_one_seed_counts_noise_as_signal():
    unit = np.array([0.4, 0.6])
    differences = seed_differences(noisy_render, unit, list(range(8)))
    assert differences.shape == (8, 2, 16, 16, 3)
    pixels = differences.reshape(8, 2, -1, 3)
    truth = 256 * (SLOPES / SIGMA) @ (SLOPES / SIGMA).T  # J^T C^-1 J over 256 pixels
    split = render_information(pixels, np.full(3, SIGMA**2))
    one_seed = render_information(np.repeat(pixels[:1], 2, axis=0), np.full(3, SIGMA**2))
    assert split == pytest.approx(truth, rel=0.15, abs=30)
    assert np.trace(one_seed) > 3 * np.trace(truth)  # the noise of 768 differences over a step of 0.1


def test_the_floor_is_the_gaussian_posterior_and_the_prior_where_nothing_shows():
    information = np.array([[3.0, 1.0], [1.0, 2.0]])
    prior = np.diag([1.0, 2.0])
    assert parameter_floor(information, prior) == pytest.approx(np.linalg.inv(information + np.linalg.inv(prior)))
    assert parameter_floor(np.zeros((2, 2)), prior) == pytest.approx(prior)
    huge = parameter_floor(np.diag([1e30, 0.0]), prior)
    assert np.isfinite(huge).all() and huge[0, 0] == pytest.approx(0.0, abs=1e-12) and huge[1, 1] == pytest.approx(2.0)


def test_information_is_positive_semi_definite_for_pure_noise():
    differences = np.random.default_rng(1).normal(size=(4, 3, 50, 3))
    assert np.linalg.eigvalsh(render_information(differences, np.ones(3))).min() >= -1e-9


def test_camera_jacobian_is_the_derivative_per_stop_and_per_white_balance_shift():
    grey = np.full((2, 2, 3), 0.5)
    exposure, balance = camera_jacobian(grey)
    linear = float(srgb_to_linear(0.5))
    expected = (linear_to_srgb(linear * 2**0.01) - linear_to_srgb(linear * 2**-0.01)) / 0.02
    assert exposure[0, 0] == pytest.approx([expected] * 3, rel=1e-3)
    assert balance[0, 0, 0] > 0 and balance[0, 0, 1] == 0 and balance[0, 0, 2] == pytest.approx(-balance[0, 0, 0])
    black, white = camera_jacobian(np.zeros((1, 1, 3))), camera_jacobian(np.ones((1, 1, 3)))
    assert np.isfinite(black).all() and black[0].max() == 0.0  # nothing to brighten
    assert white[0, 0, 0, 0] == pytest.approx(float(linear_to_srgb(1.0) - linear_to_srgb(2**-0.05)) / 0.1, rel=1e-4)


def test_masked_block_means_keep_the_blocks_mostly_inside_the_mask():
    images = np.arange(2 * 8 * 8 * 3, dtype=np.float64).reshape(2, 8, 8, 3)
    mask = np.zeros((8, 8), bool)
    mask[:4, :3] = True  # 3/4 of the top-left 4x4 block, nothing of the others
    blocks = masked_block_means(images, mask, 4)
    assert blocks.shape == (2, 1, 3)
    assert blocks[0, 0] == pytest.approx(images[0, :4, :4].mean((0, 1)))


def test_noise_variance_pools_the_seeds_deviations_per_channel():
    renders = np.random.default_rng(2).normal(0.5, [0.01, 0.02, 0.04], (6, 40, 40, 3))
    assert np.sqrt(noise_variance(renders)) == pytest.approx([0.01, 0.02, 0.04], rel=0.05)
