"""Image similarity metrics (MSE, MAE, PSNR, SSIM) on numpy arrays (H,W) or (H,W,C)."""

import numpy as np

from vto_core.errors import VtoError

# MSE is floored at data_range**2 * this, so identical images give 100 dB.
_MSE_FLOOR_RATIO = 1e-10
_SSIM_WINDOW_SIZE = 11
_SSIM_MIN_WINDOW_SIZE = 3
_SSIM_SIGMA = 1.5
_SSIM_K1 = 0.01
_SSIM_K2 = 0.03


def _checked_pair(a, b, what):
    """Return a, b as float64 arrays of one shape, (H,W) or (H,W,C), all finite."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise VtoError(f"{what}: image shapes differ, {a.shape} vs {b.shape}")
    if a.ndim not in (2, 3) or a.size == 0:
        raise VtoError(f"{what}: images have shape {a.shape}, expected non-empty (H,W) or (H,W,C)")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise VtoError(f"{what}: images contain NaN or inf")
    return a, b


def _selected_differences(a, b, mask, what):
    """Return a - b over the pixels selected by mask (H,W), flattened over pixels and channels."""
    a, b = _checked_pair(a, b, what)
    difference = a - b
    if mask is None:
        return difference.ravel()
    mask = np.asarray(mask)
    if mask.shape != a.shape[:2]:
        raise VtoError(f"{what}: mask has shape {mask.shape}, expected {a.shape[:2]}")
    selected = mask if mask.dtype == bool else mask > 0.5
    if not selected.any():
        raise VtoError(f"{what}: mask selects no pixels")
    return difference[selected].ravel()


def mse(a, b, mask=None):
    """Mean squared error of a, b (H,W) or (H,W,C) over pixels where mask (H,W) is true or > 0.5."""
    return float(np.mean(np.square(_selected_differences(a, b, mask, "mse"))))


def mae(a, b, mask=None):
    """Mean absolute error of a, b (H,W) or (H,W,C) over pixels where mask (H,W) is true or > 0.5."""
    return float(np.mean(np.abs(_selected_differences(a, b, mask, "mae"))))


def psnr(a, b, data_range=1.0, mask=None):
    """PSNR in dB of a, b (H,W) or (H,W,C) over masked pixels; identical images give 100.0 dB."""
    if not data_range > 0:
        raise VtoError(f"psnr: data_range must be positive, got {data_range}")
    peak_squared = float(data_range) ** 2
    squared_error = float(np.mean(np.square(_selected_differences(a, b, mask, "psnr"))))
    squared_error = max(squared_error, peak_squared * _MSE_FLOOR_RATIO)
    return float(10.0 * np.log10(peak_squared / squared_error))


def _gaussian_kernel(size, sigma):
    """Normalised 1-D Gaussian weights (size,) centred on the middle tap."""
    offsets = np.arange(size, dtype=np.float64) - (size - 1) / 2.0
    weights = np.exp(-(offsets**2) / (2.0 * sigma**2))
    return weights / weights.sum()


def _filter_valid(image, kernel):
    """Separable 'valid' filtering of image (H,W,C) by kernel (K,): result (H-K+1, W-K+1, C)."""
    size = kernel.size
    rows = image.shape[0] - size + 1
    columns = image.shape[1] - size + 1
    # The kernel is symmetric, so correlation equals convolution.
    vertical = sum(kernel[k] * image[k : k + rows] for k in range(size))
    return sum(kernel[k] * vertical[:, k : k + columns] for k in range(size))


def ssim(a, b, data_range=1.0):
    """Mean SSIM (Wang et al. 2004) of a, b (H,W) or (H,W,C), averaged over channels.

    Gaussian window 11x11, sigma 1.5, K1=0.01, K2=0.03, evaluated only where
    the window fits inside the image (no padding), with population (not
    sample) variances as in the reference MATLAB code.  Images under 11 px
    on a side use the largest odd window that fits (still sigma 1.5, weights
    renormalised); images under 3 px on a side raise VtoError.
    """
    if not data_range > 0:
        raise VtoError(f"ssim: data_range must be positive, got {data_range}")
    a, b = _checked_pair(a, b, "ssim")
    if a.ndim == 2:
        a, b = a[:, :, np.newaxis], b[:, :, np.newaxis]
    shortest_side = min(a.shape[0], a.shape[1])
    if shortest_side < _SSIM_MIN_WINDOW_SIZE:
        raise VtoError(
            f"ssim: images of shape {a.shape} are smaller than the {_SSIM_MIN_WINDOW_SIZE}-px window"
        )
    window_size = min(_SSIM_WINDOW_SIZE, shortest_side if shortest_side % 2 else shortest_side - 1)
    kernel = _gaussian_kernel(window_size, _SSIM_SIGMA)

    c1 = (_SSIM_K1 * data_range) ** 2
    c2 = (_SSIM_K2 * data_range) ** 2
    mean_a = _filter_valid(a, kernel)
    mean_b = _filter_valid(b, kernel)
    variance_a = _filter_valid(a * a, kernel) - mean_a**2
    variance_b = _filter_valid(b * b, kernel) - mean_b**2
    covariance = _filter_valid(a * b, kernel) - mean_a * mean_b
    ssim_map = ((2 * mean_a * mean_b + c1) * (2 * covariance + c2)) / (
        (mean_a**2 + mean_b**2 + c1) * (variance_a + variance_b + c2)
    )
    return float(ssim_map.mean(axis=(0, 1)).mean())


def block_means(image, block=4):
    """(..., H, W, C) or (H, W) -> (..., H//block, W//block, C) block averages (edge rows/columns that do not fill a
    block are dropped)."""
    image = np.asarray(image, dtype=np.float64)
    if image.ndim == 2:
        image = image[..., np.newaxis]
    *lead, height, width, channels = image.shape
    rows, columns = height // block, width // block
    if rows == 0 or columns == 0:
        raise VtoError(f"block_means: image {(height, width)} is smaller than one {block}x{block} block")
    cropped = image[..., : rows * block, : columns * block, :]
    return cropped.reshape(*lead, rows, block, columns, block, channels).mean(axis=(-4, -2))


def visibility_ratio(low_seed0, high_seed1, low_seed1, block=4, mask=None):
    """How far a parameter change stands above render noise, on block means of (H, W, C) renders.

    change = RMS(B(R(high; seed 1)) - B(R(low; seed 0))), noise = RMS(B(R(low; seed 1)) - B(R(low; seed 0))):
    both are differences of two independently seeded renders, so a parameter the image cannot show
    gives about 1, and a ratio r means the change alone is sqrt(r^2 - 1) times the noise. With `mask` (H, W),
    only blocks at least half inside it count (the lips or the hair, not the backdrop's noise).
    """
    base = block_means(low_seed0, block)
    change = np.square(block_means(high_seed1, block) - base)
    noise = np.square(block_means(low_seed1, block) - base)
    if mask is not None:
        inside = block_means(np.asarray(mask, dtype=np.float64), block)[..., 0] >= 0.5
        if not inside.any():
            raise VtoError("visibility_ratio: the mask covers no block")
        change, noise = change[inside], noise[inside]
    return float(np.sqrt(change.mean()) / max(np.sqrt(noise.mean()), 1e-12))
