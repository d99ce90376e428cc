"""Parameter sampling (paper 6.1): a normal fitted on presets, alternated with uniform draws."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import VtoError
from .specs import RendererSpec

# Streams of one sample's random numbers, so adding a use never shifts another's draws.
_STREAM_MIXTURE, _STREAM_SENSITIVITY = 0, 1
_MAX_REJECTIONS = 64


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

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """One draw truncated to [0,1] by rejecting whole vectors (keeps correlations); wraps taken mod 1: (m,)."""
        for _ in range(_MAX_REJECTIONS):
            sample = self.mean + self.cholesky @ rng.standard_normal(self.mean.size)
            if not (~self.wraps & ((sample < 0) | (sample > 1))).any():
                break
        return np.where(self.wraps, sample % 1.0, np.clip(sample, 0.0, 1.0))


def _wrap_offset(delta: np.ndarray) -> np.ndarray:
    """Signed distance on the unit circle, in [-0.5, 0.5)."""
    return (delta + 0.5) % 1.0 - 0.5


class ParamSampler:
    """Deterministic sampler: sample i is a pure function of (seed, i)."""

    def __init__(self, spec: RendererSpec, unit_presets: np.ndarray | None, uniform_ratio: float = 0.5, seed: int = 0):
        if not 0.0 <= uniform_ratio <= 1.0:
            raise VtoError(f"uniform_ratio must be in [0, 1], got {uniform_ratio}")
        if unit_presets is None and uniform_ratio < 1.0:
            raise VtoError("sampling from presets needs presets; pass uniform_ratio=1 to sample uniformly")
        if seed < 0:
            raise VtoError(f"seed must be >= 0, got {seed}")
        self.spec = spec
        self.seed = int(seed)
        self.uniform_ratio = float(uniform_ratio)
        self.normal = PresetNormal.fit(spec, unit_presets) if uniform_ratio < 1.0 else None

    def _rng(self, index: int, stream: int, *extra: int) -> np.random.Generator:
        if index < 0:
            raise VtoError(f"sample index must be >= 0, got {index}")
        return np.random.default_rng([self.seed, int(index), stream, *extra])

    def sample_unit(self, index: int) -> np.ndarray:
        """Normalised parameter vector of sample `index`: (m,) float64 in [0,1]."""
        rng = self._rng(index, _STREAM_MIXTURE)
        if rng.random() < self.uniform_ratio:
            return rng.random(self.spec.size)
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
