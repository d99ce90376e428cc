"""Parameter sampling (paper 6.1): a normal fitted on presets, alternated with uniform draws."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from statistics import NormalDist

import numpy as np

from .colour import lightness_luminance, linear_to_srgb, relative_luminance, srgb_to_linear
from .errors import VtoError
from .specs import RendererSpec

# Streams of one sample's random numbers, so adding a use never shifts another's draws.
_STREAM_MIXTURE, _STREAM_SENSITIVITY = 0, 1
# Gibbs sweeps per draw. In whitened coordinates the target is isotropic, so the chain only has to forget its start
# (the clipped mean). Worst case, the full 17-parameter lipstick fit (the box holds 1.2 % of the normal's mass):
# against a 300,000-draw rejection reference, 10,000 draws miss the marginal means by 0.042, 0.019, 0.007, 0.004
# after 1-4 sweeps (KS distance 0.31, 0.07, 0.027, 0.015), and from 4 sweeps on sit at the noise of an exact sample
# of that size (0.003, KS 0.015). The error shrinks ~2.5x a sweep, so 6 leaves ~5e-4; measured at ~1 ms a draw.
_GIBBS_SWEEPS = 6
_INSIDE = 1e-9  # the start is moved this far inside the box
_SQRT_HALF, _LOG_2, _STANDARD_NORMAL = math.sqrt(0.5), math.log(2.0), NormalDist()
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
COLOUR = ("red", "green", "blue")  # a product's colour, 8-bit sRGB, which uniform_lightness moves


@dataclass(frozen=True)
class PresetNormal:
    """A multivariate normal in normalised space; wrapping dimensions are centred on their circular mean."""

    mean: np.ndarray  # (m,)
    cholesky: np.ndarray  # (m, m)
    wraps: np.ndarray  # (m,) bool

    @classmethod
    def fit(cls, spec: RendererSpec, unit_presets: np.ndarray, jitter: float = 1e-4) -> "PresetNormal":
        """Fit on presets (n, m) in [0,1]; `jitter` keeps constant columns sampleable."""
        unit_presets = np.asarray(unit_presets, dtype=np.float64)
        if unit_presets.ndim != 2 or unit_presets.shape[1] != spec.size or len(unit_presets) < 2:
            raise VtoError(f"need at least 2 presets of {spec.size} values, got shape {unit_presets.shape}")
        wraps = np.array([p.wraps for p in spec.modelled_params])
        angle = unit_presets[:, wraps] * 2 * np.pi
        centre = np.zeros(spec.size)
        centre[wraps] = (np.arctan2(np.sin(angle).mean(0), np.cos(angle).mean(0)) / (2 * np.pi)) % 1.0
        centred = np.where(wraps, _wrap_offset(unit_presets - centre), unit_presets)
        mean = np.where(wraps, centre + centred.mean(0), centred.mean(0))
        cov = np.atleast_2d(np.cov(centred, rowvar=False)) + jitter * np.eye(spec.size)
        return cls(mean, np.linalg.cholesky(cov), wraps)

    @cached_property
    def _chain(self) -> tuple[list[float], list[float], list[list[tuple[int, float, bool]]]]:
        """Gibbs start (x, z) and, per column k of L, its non-zero rows as (row, value, row is boxed)."""
        x = np.where(self.wraps, self.mean, np.clip(self.mean, _INSIDE, 1 - _INSIDE))
        z = np.linalg.solve(self.cholesky, x - self.mean)
        columns = [[(i, float(c), not self.wraps[i]) for i, c in enumerate(self.cholesky[:, k]) if abs(c) > 1e-12]
                   for k in range(self.mean.size)]
        return x.tolist(), z.tolist(), columns

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """One draw from the normal truncated to the unit box (wrapping dimensions free, taken mod 1): (m,).

        Gibbs sampling in whitened coordinates z (x = mean + L z, z ~ N(0, I) restricted to the box): each z_k in
        turn is drawn from a standard normal truncated to the interval the box allows given the others. The
        chain stays inside the box, so nothing is clipped and correlations are kept. Scalar Python arithmetic:
        numpy's per-call cost would dominate at this size.
        """
        start_x, start_z, columns = self._chain
        x, z = list(start_x), list(start_z)
        uniforms = rng.random((_GIBBS_SWEEPS, len(z))).tolist()
        for sweep in uniforms:
            for k, column in enumerate(columns):
                low, high = -math.inf, math.inf  # the step d with 0 <= x_i + c_i d <= 1 on every boxed row
                for i, c, boxed in column:
                    if boxed:
                        to_zero, to_one = -x[i] / c, (1.0 - x[i]) / c
                        if c < 0:
                            to_zero, to_one = to_one, to_zero
                        low, high = (to_zero if to_zero > low else low), (to_one if to_one < high else high)
                step = truncated_standard_normal(sweep[k], z[k] + low, z[k] + high) - z[k]
                z[k] += step
                for i, c, _ in column:
                    x[i] += c * step
        x = np.array(x)
        # The clip only absorbs rounding (~1e-16); the chain itself never leaves the box.
        return np.where(self.wraps, x % 1.0, np.clip(x, 0.0, 1.0))


def truncated_standard_normal(u: float, low: float, high: float) -> float:
    """N(0, 1) restricted to [low, high] from one uniform u in [0, 1): inverse CDF in log space, exact far in the
    tails. Within the lower tail (low <= 0) this is the quantile u; above it, minus the quantile u of the mirror."""
    if low > 0:  # work in the lower tail, where log Phi keeps its precision
        return -truncated_standard_normal(u, -high, -low)
    log_low, log_high = _log_phi(low), _log_phi(high)
    if not log_low < log_high:  # an empty or numerically zero-width window
        return min(low, high)
    # log(Phi(low) + u (Phi(high) - Phi(low))), never forming the probabilities themselves
    log_step = math.log(max(u, 1e-300)) + log_high + math.log(-math.expm1(log_low - log_high))
    top, bottom = max(log_low, log_step), min(log_low, log_step)
    log_u = top + math.log1p(math.exp(bottom - top)) if bottom > -math.inf else top
    return min(max(_phi_inverse_of_log(log_u), low), high)


def _log_phi(x: float) -> float:
    """log Phi(x) of the standard normal CDF, finite for every finite x."""
    if x > -37.0:  # Phi(-37) = 6e-300 is still a normal float; erfc keeps its relative precision down to there
        return math.log(0.5 * math.erfc(-x * _SQRT_HALF))
    # The asymptotic series Phi(x) = phi(x)/|x| (1 - 1/x^2 + 3/x^4 - 15/x^6 + 105/x^8 ...): below -37 its first
    # omitted term is under 1e-12 of the sum. Pure Python, because Blender's Python has no scipy.
    r = 1.0 / (x * x)
    series = 1.0 - r * (1.0 - 3.0 * r * (1.0 - 5.0 * r * (1.0 - 7.0 * r)))
    return -0.5 * x * x - math.log(-x) - _LOG_SQRT_2PI + math.log(series)


def _phi_inverse_of_log(log_p: float) -> float:
    """x with log Phi(x) = log_p <= 0, finite for every finite log_p (|x| <= 37 above log_p = -690)."""
    if log_p > -_LOG_2:  # upper half: invert the complement 1 - p, which keeps its precision there
        return -_STANDARD_NORMAL.inv_cdf(max(-math.expm1(log_p), 1e-300))
    if log_p > -690.0:  # p > 1e-300
        return _STANDARD_NORMAL.inv_cdf(math.exp(log_p))
    # Newton on log Phi(x) = log_p from the leading-order root; its slope phi/Phi is formed in log space.
    x = -math.sqrt(-2.0 * log_p)
    for _ in range(50):
        log_phi_x = _log_phi(x)
        step = (log_phi_x - log_p) / math.exp(-0.5 * x * x - _LOG_SQRT_2PI - log_phi_x)
        x -= step
        if abs(step) <= 1e-15 * abs(x):
            break
    return x


def _wrap_offset(delta: np.ndarray) -> np.ndarray:
    """Signed distance on the unit circle, in [-0.5, 0.5)."""
    return (delta + 0.5) % 1.0 - 0.5


@dataclass(frozen=True)
class PresetKernels:
    """Each preset with a normal of width `width` about it (a kernel density): the presets' own spread kept, where
    one normal fitted on them puts its mass at their middle (lipstick: 19 % of the presets are darker than L* 20,
    2 % of that normal's draws)."""

    presets: np.ndarray  # (n, m) in [0, 1]
    width: float
    wraps: np.ndarray  # (m,) bool

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """A preset drawn at random, moved by N(0, width^2) per value; wrapping values taken mod 1, the others
        reflected back into [0, 1]: (m,)."""
        moved = self.presets[rng.integers(len(self.presets))] + rng.normal(0.0, self.width, self.presets.shape[1])
        reflected = 1.0 - np.abs(1.0 - np.abs(moved))
        return np.where(self.wraps, moved % 1.0, np.clip(reflected, 0.0, 1.0))


def at_lightness(srgb: np.ndarray, lightness: float) -> np.ndarray:
    """An sRGB colour (3,) in [0, 1] moved to CIELAB lightness `lightness` in [0, 100], its hue kept: darkened by
    scaling its linear light, lightened by mixing it with white in linear light: (3,) in [0, 1]."""
    linear = srgb_to_linear(srgb).astype(np.float64)
    y, target = relative_luminance(linear), lightness_luminance(lightness)
    if target <= y:
        moved = linear * (target / y) if y > 0.0 else linear
    else:
        moved = linear + (target - y) / (1.0 - y) * (1.0 - linear)
    return np.clip(linear_to_srgb(moved).astype(np.float64), 0.0, 1.0)


class ParamSampler:
    """Deterministic sampler: sample i is a pure function of (seed, i)."""

    def __init__(self, spec: RendererSpec, unit_presets: np.ndarray | None, uniform_ratio: float = 0.5, seed: int = 0,
                 kernel: float = 0.0, uniform_lightness: bool = False, uniform_params: tuple[str, ...] = ()):
        """kernel: 0 draws the non-uniform share from one normal fitted on the presets (the paper's); above 0, from
        PresetKernels of that width (unit range). uniform_lightness: each uniform draw's colour is moved to a CIELAB
        lightness drawn uniformly in [0, 100] (at_lightness), so dark and light products are as common as middling
        ones (the RGB cube puts 3 % of its colours below L* 20). uniform_params: when given, a uniform draw spreads
        only these parameters and takes the others from a preset draw (a colour drawn anywhere, worn with a finish
        products have: an even finish puts a matte's sheen at 0.5)."""
        if not 0.0 <= uniform_ratio <= 1.0:
            raise VtoError(f"uniform_ratio must be in [0, 1], got {uniform_ratio}")
        if not 0.0 <= kernel <= 0.5:
            raise VtoError(f"the preset kernel's width must be in [0, 0.5], got {kernel}")
        if unit_presets is None and uniform_ratio < 1.0:
            raise VtoError("sampling from presets needs presets; pass uniform_ratio=1 to sample uniformly")
        if seed < 0:
            raise VtoError(f"seed must be >= 0, got {seed}")
        self.spec = spec
        self.seed = int(seed)
        self.uniform_ratio = float(uniform_ratio)
        self.normal = None
        self.colour = None  # positions of COLOUR in spec.modelled where uniform_lightness moves them
        self.from_presets = None  # positions a uniform draw takes from a preset draw (uniform_params)
        if uniform_lightness:
            if not set(COLOUR) <= set(spec.modelled):
                raise VtoError(f"uniform lightness moves a modelled colour ({', '.join(COLOUR)}); {spec.renderer} "
                               f"models {', '.join(spec.modelled)}")
            self.colour = [spec.modelled.index(name) for name in COLOUR]
        if uniform_params:
            unknown = sorted(set(uniform_params) - set(spec.modelled))
            if unknown:
                raise VtoError(f"uniform parameters must be modelled: {', '.join(unknown)} is not among "
                               f"{', '.join(spec.modelled)}")
            if not 0.0 < uniform_ratio < 1.0:
                raise VtoError("uniform parameters mix uniform and preset draws: uniform_ratio must be in (0, 1), "
                               f"got {uniform_ratio}")
            self.from_presets = [i for i, name in enumerate(spec.modelled) if name not in uniform_params]
        if uniform_ratio < 1.0:
            wraps = np.array([p.wraps for p in spec.modelled_params])
            self.normal = (PresetKernels(np.asarray(unit_presets, np.float64), kernel, wraps) if kernel > 0
                           else PresetNormal.fit(spec, unit_presets))

    def _rng(self, index: int, stream: int, *extra: int) -> np.random.Generator:
        if index < 0:
            raise VtoError(f"sample index must be >= 0, got {index}")
        return np.random.default_rng([self.seed, int(index), stream, *extra])

    def sample_unit(self, index: int) -> np.ndarray:
        """Normalised parameter vector of sample `index`: (m,) float64 in [0,1]."""
        rng = self._rng(index, _STREAM_MIXTURE)
        if rng.random() < self.uniform_ratio:
            unit = rng.random(self.spec.size)
            if self.colour is not None:
                raw = self.spec.denormalise(unit)
                raw[self.colour] = 255.0 * at_lightness(raw[self.colour] / 255.0, 100.0 * rng.random())
                unit[self.colour] = self.spec.normalise(raw)[self.colour]
            if self.from_presets is not None:
                unit[self.from_presets] = self.normal.draw(rng)[self.from_presets]
            return unit
        return self.normal.draw(rng)

    def sample(self, index: int) -> np.ndarray:
        """Raw parameter vector of sample `index`: (m,) float64."""
        return self.spec.denormalise(self.sample_unit(index))

    def resample_one_unit(self, index: int, j: int) -> np.ndarray:
        """Sample `index` with only element j redrawn uniformly (the sensitivity loss's g'_ij): (m,)."""
        if not 0 <= j < self.spec.size:
            raise VtoError(f"parameter index {j} outside 0..{self.spec.size - 1}")
        unit = self.sample_unit(index).copy()
        unit[j] = self._rng(index, _STREAM_SENSITIVITY, j).random()
        return unit
