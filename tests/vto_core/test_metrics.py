"""Tests for vto_core.metrics: MSE, MAE, PSNR and SSIM."""

import math

import numpy as np
import pytest

from vto_core.errors import VtoError
from vto_core.metrics import mae, mse, psnr, ssim


def _random_image(seed, shape=(24, 20, 3)):
    """A reproducible random image in [0, 1]."""
    return np.random.default_rng(seed).random(shape)


def _naive_ssim(a, b, window_size=11, sigma=1.5, data_range=1.0):
    """Direct SSIM: a 2-D Gaussian window visited at every valid position, per channel."""
    offsets = np.arange(window_size) - (window_size - 1) / 2.0
    weights_1d = np.exp(-(offsets**2) / (2 * sigma**2))
    window = np.outer(weights_1d, weights_1d)
    window /= window.sum()
    c1 = (0.01 * data_range) ** 2
    c2 = (0.03 * data_range) ** 2
    channel_means = []
    for channel in range(a.shape[2]):
        values = []
        for top in range(a.shape[0] - window_size + 1):
            for left in range(a.shape[1] - window_size + 1):
                patch_a = a[top : top + window_size, left : left + window_size, channel]
                patch_b = b[top : top + window_size, left : left + window_size, channel]
                mean_a = np.sum(window * patch_a)
                mean_b = np.sum(window * patch_b)
                variance_a = np.sum(window * (patch_a - mean_a) ** 2)
                variance_b = np.sum(window * (patch_b - mean_b) ** 2)
                covariance = np.sum(window * (patch_a - mean_a) * (patch_b - mean_b))
                values.append(
                    (2 * mean_a * mean_b + c1)
                    * (2 * covariance + c2)
                    / ((mean_a**2 + mean_b**2 + c1) * (variance_a + variance_b + c2))
                )
        channel_means.append(np.mean(values))
    return float(np.mean(channel_means))


def test_psnr_of_identical_images_is_100_db():
    image = _random_image(0)
    assert psnr(image, image) == pytest.approx(100.0, abs=1e-9)
    assert psnr(image * 255, image * 255, data_range=255.0) == pytest.approx(100.0, abs=1e-9)


def test_psnr_of_constant_offset_matches_hand_computation():
    image = np.full((8, 9, 3), 0.4)
    # MSE = 0.01, so PSNR = 10 log10(1 / 0.01) = 20 dB.
    assert psnr(image, image + 0.1) == pytest.approx(20.0, abs=1e-9)
    # Same error relative to a range of 2: 10 log10(4 / 0.01).
    assert psnr(image, image + 0.1, data_range=2.0) == pytest.approx(10 * math.log10(400.0), abs=1e-9)


def test_psnr_ignores_differences_outside_the_mask():
    reference = np.full((6, 6, 3), 0.5)
    inside_only = reference.copy()
    inside_only[:3] += 0.1
    both = inside_only.copy()
    both[3:] = 0.0
    mask = np.zeros((6, 6), dtype=bool)
    mask[:3] = True
    assert psnr(reference, inside_only, mask=mask) == pytest.approx(20.0, abs=1e-9)
    assert psnr(reference, both, mask=mask) == pytest.approx(20.0, abs=1e-9)
    # A float mask selects where it is above 0.5.
    assert psnr(reference, both, mask=mask * 0.9 + 0.05) == pytest.approx(20.0, abs=1e-9)
    assert psnr(reference, both) < 20.0


def test_psnr_with_empty_mask_raises():
    image = _random_image(1)
    with pytest.raises(VtoError, match="no pixels"):
        psnr(image, image, mask=np.zeros(image.shape[:2], dtype=bool))


@pytest.mark.parametrize("metric", [psnr, ssim, mse, mae])
def test_shape_mismatch_raises(metric):
    with pytest.raises(VtoError, match="shapes differ"):
        metric(np.zeros((12, 12, 3)), np.zeros((12, 13, 3)))


def test_mask_of_wrong_shape_raises():
    with pytest.raises(VtoError, match="mask"):
        psnr(np.zeros((4, 4)), np.zeros((4, 4)), mask=np.ones((4, 5), dtype=bool))


def test_mse_and_mae_on_a_known_difference():
    a = np.zeros((2, 2))
    b = np.array([[0.1, -0.3], [0.0, 0.2]])
    assert mse(a, b) == pytest.approx((0.01 + 0.09 + 0.04) / 4)
    assert mae(a, b) == pytest.approx(0.6 / 4)
    assert mae(a, b, mask=np.array([[True, False], [False, False]])) == pytest.approx(0.1)


def test_metrics_refuse_non_finite_input():
    image = _random_image(2)
    broken = image.copy()
    broken[0, 0, 0] = np.nan
    with pytest.raises(VtoError, match="NaN"):
        psnr(image, broken)
    with pytest.raises(VtoError, match="NaN"):
        ssim(image, broken)


def test_ssim_of_an_image_with_itself_is_one():
    image = _random_image(3)
    assert ssim(image, image) == pytest.approx(1.0, abs=1e-12)
    assert ssim(image[:, :, 0], image[:, :, 0]) == pytest.approx(1.0, abs=1e-12)


def test_ssim_of_constant_images_is_finite():
    constant = np.full((16, 16, 3), 0.25)
    assert ssim(constant, constant) == pytest.approx(1.0, abs=1e-12)
    other = ssim(constant, np.full((16, 16, 3), 0.75))
    assert math.isfinite(other)
    assert 0.0 < other < 1.0


@pytest.mark.parametrize("shape", [(17, 19, 3), (13, 12, 1)])
def test_ssim_matches_direct_implementation(shape):
    a = _random_image(4, shape)
    b = np.clip(a + 0.2 * _random_image(5, shape) - 0.1, 0.0, 1.0)
    assert ssim(a, b) == pytest.approx(_naive_ssim(a, b), abs=1e-6)


def test_ssim_on_small_image_uses_largest_odd_window():
    # 8 px on the short side: a 7x7 window.
    a = _random_image(6, (8, 10, 2))
    b = np.clip(a + 0.1 * _random_image(7, (8, 10, 2)), 0.0, 1.0)
    assert ssim(a, b) == pytest.approx(_naive_ssim(a, b, window_size=7), abs=1e-6)


def test_ssim_on_image_below_three_pixels_raises():
    with pytest.raises(VtoError, match="window"):
        ssim(np.zeros((2, 9)), np.zeros((2, 9)))


def test_ssim_decreases_as_noise_increases():
    rows, columns = np.mgrid[0:32, 0:32]
    clean = np.stack(
        [0.5 + 0.4 * np.sin(rows / 4.0 + channel) * np.cos(columns / 5.0) for channel in range(3)], axis=2
    )
    noise = np.random.default_rng(8).standard_normal(clean.shape)
    scores = [ssim(clean, clean + sigma * noise) for sigma in (0.0, 0.02, 0.05, 0.1, 0.3)]
    assert scores[0] == pytest.approx(1.0)
    assert all(later < earlier for earlier, later in zip(scores, scores[1:]))
    assert scores[-1] < 0.5


SKIMAGE_SSIM = dict(gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=1.0)


@pytest.mark.parametrize("shape, noise", [((24, 30, 3), 0.1), ((11, 11, 3), 0.05), ((64, 64, 3), 0.3),
                                          ((32, 17, 1), 0.1), ((40, 12, 4), 0.02)])
def test_ssim_equals_scikit_image(shape, noise):
    """scikit-image 0.26 structural_similarity with the Wang et al. settings, on images of 11 px and more."""
    from skimage.metrics import structural_similarity

    rng = np.random.default_rng(sum(shape))
    a = rng.random(shape)
    b = np.clip(a + rng.normal(0, noise, a.shape), 0, 1)
    expected = structural_similarity(a, b, channel_axis=-1, **SKIMAGE_SSIM)
    assert ssim(a, b) == pytest.approx(expected, abs=1e-12)
    assert ssim(a[..., 0], b[..., 0]) == pytest.approx(structural_similarity(a[..., 0], b[..., 0], **SKIMAGE_SSIM),
                                                       abs=1e-12)


def test_ssim_equals_scikit_image_on_flat_and_opposite_images():
    from skimage.metrics import structural_similarity

    flat, ramp = np.full((16, 16, 3), 0.25), np.linspace(0, 1, 16 * 16 * 3).reshape(16, 16, 3)
    for a, b in ((flat, flat), (flat, np.full((16, 16, 3), 0.75)), (ramp, 1 - ramp)):
        assert ssim(a, b) == pytest.approx(structural_similarity(a, b, channel_axis=-1, **SKIMAGE_SSIM), abs=1e-12)


def test_scikit_image_refuses_what_ssim_still_measures():
    """Why vto_core keeps its own SSIM: scikit-image needs 11 px, the encoder's thumbnails can be smaller."""
    from skimage.metrics import structural_similarity

    a = _random_image(9, (8, 10, 3))
    with pytest.raises(ValueError):
        structural_similarity(a, a * 0.9, channel_axis=-1, **SKIMAGE_SSIM)
    assert 0.0 < ssim(a, a * 0.9) < 1.0
