"""Which parameters a render can show: a quartile change of one parameter against render noise."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .metrics import block_means, visibility_ratio
from .products import get_product
from .specs import ParamSpec

VISIBLE_RATIO = 3.0  # the change must stand this far above seed-to-seed noise (4x4 block means)
# The look each parameter is measured on: the product's look (lipstick fully on); inputs that only act on a layer get
# that layer where the product has layers (flakes for the sparkle inputs, a glossy coat, gloss at its 75th percentile,
# for its roughness; a pearl shimmer for the shimmer's roughness and tint). A modelled parameter stands above the bar;
# one under it is left out of the spec, with its measured ratio as the reason (`vto spec` names it in "left_out").
_CONTEXT = {"sparkle": {"sparkle_density": 0.5, "sparkle_intensity": 0.75}, "gloss_roughness": {"gloss": 2.0},
            "shimmer_": {"shimmer": 0.75}}


def measurement_look(renderer: str, name: str) -> dict[str, float]:
    """The parameter values (besides `name`) a visibility measurement of `name` starts from."""
    context = next((values for prefix, values in _CONTEXT.items() if name.startswith(prefix)), {})
    product = get_product(renderer)
    return {**product.look, **(context if product.kind.layer_looks else {})}


def quartile_values(param: ParamSpec) -> tuple[float, float]:
    """The 25th and 75th percentile of a parameter's sampling range (unit space 0.25 and 0.75)."""
    return param.from_unit(0.25), param.from_unit(0.75)


def parameter_visibility(render: Callable[[dict[str, float], int], np.ndarray], param: ParamSpec,
                         base: dict[str, float], block: int = 4, mask: np.ndarray | None = None) -> float:
    """visibility_ratio of moving `param` from its 25th to its 75th percentile on top of `base`.

    render(values, cycles_seed) -> (H, W, 3) image; three renders: low on seeds 0 and 1, high on seed 1.
    """
    low, high = quartile_values(param)
    low_values, high_values = {**base, param.name: low}, {**base, param.name: high}
    return visibility_ratio(render(low_values, 0), render(high_values, 1), render(low_values, 1), block, mask)


def step_visibility(render: Callable[[dict[str, float], int], np.ndarray], param: ParamSpec, base: dict[str, float],
                    points: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0), block: int = 4,
                    mask: np.ndarray | None = None) -> list[float]:
    """visibility_ratio of each step of `param` between consecutive unit-space `points` on top of `base`.

    Equal steps of an encoded parameter should be about equally visible; a list that falls along the range says
    that the encoding spends its top on changes the render cannot show. Three renders a step, as parameter_visibility.
    """
    ratios = []
    for low_unit, high_unit in zip(points, points[1:]):
        low = {**base, param.name: param.from_unit(low_unit)}
        high = {**base, param.name: param.from_unit(high_unit)}
        ratios.append(visibility_ratio(render(low, 0), render(high, 1), render(low, 1), block, mask))
    return ratios


# How precisely one render pins the parameters (a floor for any reader of that render, learned or not): the render's
# derivatives against its seed-to-seed noise, linearised about a look, with the sampler's spread as prior. A changed
# parameter changes which light paths Cycles samples, so two renders on one seed differ by noise as well as by the
# change: derivatives are taken on several seeds, and the information from two independent halves of them.

def seed_differences(render: Callable[[np.ndarray, int], np.ndarray], unit: np.ndarray, seeds: list[int],
                     step: float = 0.05) -> np.ndarray:
    """render(unit (P,), cycles_seed) -> image (...); returns (K, P, ...) central differences d image / d unit on each
    of the K seeds, kept inside [0, 1] (one-sided at the ends). 2 K renders a parameter."""
    unit = np.asarray(unit, np.float64)
    out = []
    for seed in seeds:
        columns = []
        for j in range(unit.size):
            low, high = unit.copy(), unit.copy()
            low[j], high[j] = max(unit[j] - step, 0.0), min(unit[j] + step, 1.0)
            columns.append((np.asarray(render(high, seed), np.float64) - render(low, seed)) / (high[j] - low[j]))
        out.append(np.stack(columns))
    return np.stack(out)


def camera_jacobian(image: np.ndarray, step: float = 0.05) -> np.ndarray:
    """image (H, W, 3) display sRGB in [0, 1] -> (2, H, W, 3): its change per stop of exposure and per unit of the
    white-balance shift d (linear gains 1 + d, 1, 1 - d), the two residual errors of the default scene's camera."""
    from .colour import linear_to_srgb, srgb_to_linear

    linear = srgb_to_linear(np.clip(image, 0.0, 1.0)).astype(np.float64)

    def shown(gains):
        return linear_to_srgb(np.clip(linear * gains, 0.0, 1.0)).astype(np.float64)

    exposure = (shown(2.0**step) - shown(2.0**-step)) / (2.0 * step)
    tint = np.array([1.0, 0.0, -1.0])
    balance = (shown(1.0 + step * tint) - shown(1.0 - step * tint)) / (2.0 * step)
    return np.stack([exposure, balance])


def masked_block_means(images: np.ndarray, mask: np.ndarray, block: int = 4) -> np.ndarray:
    """images (..., H, W, C) -> (..., B, C): the block means (metrics.block_means) of the B blocks at least half
    inside mask (H, W). Denoised render noise is smooth over a few pixels; block means are closer to independent."""
    inside = block_means(np.asarray(mask, np.float64), block)[..., 0] >= 0.5
    return block_means(images, block)[..., inside, :]


def noise_variance(renders: np.ndarray) -> np.ndarray:
    """renders (K, ..., C) of one look on K Cycles seeds -> (C,) variance about their mean, pooled over the rest."""
    renders = np.asarray(renders, np.float64)
    deviations = (renders - renders.mean(0)).reshape(renders.shape[0], -1, renders.shape[-1])
    return (deviations**2).sum((0, 1)) / max((renders.shape[0] - 1) * deviations.shape[1], 1)


def render_information(differences: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """differences (K, P, ..., C) on K >= 2 seeds, variance (C,) of one render's noise -> Fisher information (P, P).

    J^T C^-1 J with J from one half of the seeds against the other (their noise is independent, so the noise does not
    count as signal), symmetrised and kept positive semi-definite. Noise is taken as independent between the
    entries; what is left of its correlation makes this optimistic.
    """
    differences = np.asarray(differences, np.float64)
    weights = 1.0 / np.sqrt(np.maximum(np.asarray(variance, np.float64), 1e-20))
    scaled = (differences * weights).reshape(differences.shape[0], differences.shape[1], -1)
    half_a, half_b = scaled[0::2].mean(0), scaled[1::2].mean(0)
    cross = half_a @ half_b.T
    values, vectors = np.linalg.eigh((cross + cross.T) / 2.0)
    return (vectors * np.maximum(values, 0.0)) @ vectors.T


def parameter_floor(information: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """The posterior covariance (P, P) of P parameters from their information (P, P) and prior covariance (P, P):
    (F + prior^-1)^-1, finite where a parameter does not show at all (its prior comes back)."""
    information, prior = np.asarray(information, np.float64), np.asarray(prior, np.float64)
    # = S - S F (I + S F)^-1 S: no inverse of F (singular where a parameter does not show) nor of S.
    return prior - prior @ information @ np.linalg.solve(np.eye(len(prior)) + prior @ information, prior)
