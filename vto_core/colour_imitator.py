"""The colour imitator: a learned stand-in for what a renderer's default scene shows of its region (the lips' or the
hair's colour statistics, vto_core.appearance.region_statistics) as a function of the parameters (and, for lips, of
how the skin around them looks: the light and skin tone the photo shows, which colour the lips as much as the
lipstick does).

It is the paper's imitator at the level a photo needs (a photo has no source X to render on): trained on real Blender
renders of the default scene (training/train_colour.py), it lets Fast move the encoder's estimate until the default
scene would show the photo's colour, in milliseconds. Better and Best fit the same statistics through the real
renderer (blender_addon.matching.photo_fit).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .errors import VtoError
from .inference import METADATA_PREFIX, cpu_session
from .specs import RendererSpec

INPUT_NAME, OUTPUT_NAME = "params_unit", "statistics"
SKIN_SCALE = 100.0  # the skin's CIELAB enters the network divided by this
KIND = "colour_imitator"
STEP = 1e-3  # the fit's finite-difference step in unit space (the network is smooth)
SETTLED = 1e-6  # a fit whose steps gain less than this share of its cost three times in a row has settled


class ColourImitator:
    """An exported colour imitator: unit parameters (N, m) -> region statistics (N, F); fits a target."""

    def __init__(self, path: str | Path):
        path = Path(path)
        self.session = cpu_session(path, 1, "colour imitator")
        metadata = self.session.get_modelmeta().custom_metadata_map
        if metadata.get(f"{METADATA_PREFIX}kind") != KIND:
            raise VtoError(f"{path} is not a VTO colour imitator")
        self.spec = RendererSpec.from_dict(json.loads(metadata[f"{METADATA_PREFIX}spec"]))
        skin = metadata.get(f"{METADATA_PREFIX}typical_skin_lab")
        self.typical_skin = np.array(json.loads(skin), np.float64) if skin else None  # None: not skin-conditioned

    def statistics(self, unit: np.ndarray, skin_lab: np.ndarray | None = None) -> np.ndarray:
        """(N, m) or (m,) unit parameters -> (N, F) or (F,) the statistics the default scene shows (float64); a
        skin-conditioned imitator also takes the CIELAB (3,) of the skin around the region (None: a typical skin)."""
        unit = np.asarray(unit, np.float32)
        rows = unit[None] if unit.ndim == 1 else unit
        if self.typical_skin is not None:
            skin = self.typical_skin if skin_lab is None else np.asarray(skin_lab, np.float64)
            rows = np.concatenate([rows, np.broadcast_to(skin / SKIN_SCALE, (len(rows), 3)).astype(np.float32)], 1)
        out = self.session.run([OUTPUT_NAME], {INPUT_NAME: np.ascontiguousarray(rows)})[0].astype(np.float64)
        return out[0] if unit.ndim == 1 else out

    def fit(self, target: np.ndarray, start: np.ndarray, prior_weight: float, wraps: np.ndarray,
            held: dict[int, float] | None = None, skin_lab: np.ndarray | None = None,
            iterations: int = 40) -> np.ndarray:  # 12 left dark hair short of where it settles
        """The unit vector (m,) near `start` (m,) whose predicted statistics (on a face with skin `skin_lab`, where the
        imitator takes one) are closest to `target` (F,): Levenberg-Marquardt on [statistics - target;
        prior_weight (u - start)] inside the unit box, `held` dimensions fixed. Starts (S, m) give S fits (S, m), each
        near its own start, run side by side (two network calls a step for all of them)."""
        target = np.asarray(target, np.float64)
        if not np.isfinite(target).all():
            raise VtoError("the colour imitator's fit needs finite target statistics")
        starts = np.atleast_2d(np.asarray(start, np.float64)).copy()  # (S, m)
        for i, value in (held or {}).items():
            starts[:, i] = value
        count, size = starts.shape
        free = np.array([i not in (held or {}) for i in range(size)])
        wraps = np.asarray(wraps, bool)

        def residual(units: np.ndarray) -> np.ndarray:  # (S, k, m) -> (S, k, F + m)
            shift = units - starts[:, None]
            shift = np.where(wraps, (shift + 0.5) % 1.0 - 0.5, shift)
            seen = self.statistics(units.reshape(-1, size), skin_lab).reshape(count, units.shape[1], -1)
            return np.concatenate([seen - target, prior_weight * shift], axis=2)

        unit, damping = starts.copy(), np.full(count, 1e-2)
        current = residual(unit[:, None])[:, 0]  # (S, F + m)
        steps = STEP * np.eye(size)[free]  # (f, m)
        stalled = np.zeros(count, int)  # steps in a row that gained less than SETTLED of the cost, per fit
        for _ in range(iterations):
            if (stalled >= 3).all():
                break
            jacobian = (residual(unit[:, None] + steps) - current[:, None]) / STEP  # (S, f, F + m): rows per probe
            gram = jacobian @ jacobian.transpose(0, 2, 1)  # (S, f, f)
            scale = np.diagonal(gram, axis1=1, axis2=2) + 1e-9
            lhs = gram + damping[:, None, None] * (np.eye(len(steps)) * scale[:, None, :])
            move = -np.linalg.solve(lhs, (jacobian @ current[..., None]))[..., 0]  # (S, f)
            trial = unit.copy()
            trial[:, free] += move
            trial = np.where(wraps, np.mod(trial, 1.0), np.clip(trial, 0.0, 1.0))
            trial_residual = residual(trial[:, None])[:, 0]
            cost, trial_cost = (current ** 2).sum(axis=1), (trial_residual ** 2).sum(axis=1)
            better = trial_cost < cost
            # A rejected step only raises the damping; a fit has settled when its accepted steps gain next to nothing
            # or its damping is at the ceiling.
            small = better & (cost - trial_cost <= SETTLED * cost)
            stalled = np.where(better & ~small, 0, stalled + (small | (~better & (damping >= 1e6))))
            unit = np.where(better[:, None], trial, unit)
            current = np.where(better[:, None], trial_residual, current)
            damping = np.where(better, np.maximum(damping / 3, 1e-6), np.minimum(damping * 4, 1e6))
        return unit if np.ndim(start) == 2 else unit[0]


_IMITATORS: dict[tuple[str, int], ColourImitator] = {}


def cached_imitator(path: str | Path) -> ColourImitator:
    """One ColourImitator per file (and modification time), made on first use."""
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise VtoError(f"no colour imitator at {path}")
    key = (str(path), path.stat().st_mtime_ns)
    if key not in _IMITATORS:
        _IMITATORS[key] = ColourImitator(path)
    return _IMITATORS[key]
