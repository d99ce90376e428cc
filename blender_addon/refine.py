"""Derivative-free refinement through the real renderer: CMA-ES on the unit parameters, a fixed render budget."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vto_core.errors import VtoError
from vto_core.metrics import mse

SIGMA = 0.15  # initial CMA-ES step in unit space: about the encoder's typical error


@dataclass
class Refined:
    """Best unit vector (m,), its objective (MSE to the reference), renders spent, objective at the start."""

    unit: np.ndarray
    loss: float
    renders: int
    start_loss: float


def refine_by_render(render_unit: Callable[[np.ndarray], np.ndarray], reference: np.ndarray, start: np.ndarray,
                     budget: int, seed: int = 0) -> Refined:
    """Minimise MSE(render_unit(u), reference) over u in [0, 1]^m from `start` with at most `budget` renders.

    The start is rendered first and kept unless something renders closer, so the result is never worse than the
    start on this objective; every candidate stays inside the unit box (CMA-ES bounds, then a clip).
    """
    import cma

    if budget < 1:
        raise VtoError(f"a render budget needs at least 1 render, got {budget}")
    start = np.clip(np.asarray(start, np.float64), 0.0, 1.0)
    best_unit, best_loss = start, mse(render_unit(start), reference)
    start_loss, renders = best_loss, 1
    strategy = cma.CMAEvolutionStrategy(start.tolist(), SIGMA, {
        "bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "verb_log": 0, "verb_disp": 0,
        "popsize": max(4, min(8, budget // 4))})
    while renders + strategy.popsize <= budget and not strategy.stop():
        candidates = [np.clip(np.asarray(x), 0.0, 1.0) for x in strategy.ask()]
        losses = [mse(render_unit(x), reference) for x in candidates]
        renders += len(candidates)
        strategy.tell(candidates, losses)
        k = int(np.argmin(losses))
        if losses[k] < best_loss:
            best_unit, best_loss = candidates[k], losses[k]
    return Refined(best_unit, float(best_loss), renders, float(start_loss))
