"""Derivative-free refinement through the real renderer: CMA-ES on the unit parameters, an exact render budget.

Needs only numpy and `cma` (no torch): it runs inside Blender. The renderer comes in as a function of the unit
vector, so the caller fixes the source, the size and the Cycles seed (one seed for every render: the search then
compares looks, not noise).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vto_core.errors import VtoError
from vto_core.metrics import mse, ssim

SIGMA = 0.15  # initial step in unit space from the encoder's estimate: about its typical error
SIGMA_FROM_MEAN = 0.3  # from the mean preset: a look anywhere in the ranges must be reachable
OBJECTIVES = {"mse": mse, "ssim": lambda a, b: 1.0 - ssim(a, b)}


@dataclass
class Refined:
    """Best unit vector (m,), its objective, the objective at the start, and the renders spent."""

    unit: np.ndarray
    loss: float
    start_loss: float
    renders: int


def into_box(unit: np.ndarray, wraps: np.ndarray) -> np.ndarray:
    """(m,) -> (m,) inside [0, 1]: wrapping dimensions (hue) taken mod 1, the others clipped."""
    unit = np.asarray(unit, np.float64)
    return np.where(wraps, np.mod(unit, 1.0), np.clip(unit, 0.0, 1.0))


def refine_by_render(render_unit: Callable[[np.ndarray], np.ndarray], reference: np.ndarray, start: np.ndarray,
                     budget: int, seed: int = 0, wraps=None, objective: str = "mse", sigma: float = SIGMA,
                     held: dict[int, float] | None = None) -> Refined:
    """Render search to the end: see iter_refine_by_render."""
    steps = iter_refine_by_render(render_unit, reference, start, budget, seed, wraps, objective, sigma, held)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def iter_refine_by_render(render_unit: Callable[[np.ndarray], np.ndarray], reference: np.ndarray, start: np.ndarray,
                          budget: int, seed: int = 0, wraps=None, objective: str = "mse", sigma: float = SIGMA,
                          held: dict[int, float] | None = None):
    """Minimise objective(render_unit(u), reference) over u in [0, 1]^m from `start`, with at most `budget` renders.

    render_unit: (m,) unit vector -> (H, W, 3) image like `reference`; wraps: (m,) bool, dimensions that wrap (hue).
    held: {dimension: unit value} rendered at that value and left out of the search; the result keeps the start's
    values there (see blender_addon.hair.OWN_SOURCE_HELD for why).
    The start is rendered first and kept unless something renders closer, so the result is never worse than the
    start on this objective. Whole CMA-ES generations are told back; what is left of the budget at the end is spent
    on part of one more generation (evaluated, kept if better, not told), so exactly `budget` renders are made
    unless the search converges first.

    A generator: it yields the renders made so far after each render (so a modal operator can run it a few renders
    per timer tick, and show progress) and returns the Refined result (StopIteration.value).
    """
    import cma

    if budget < 1:
        raise VtoError(f"a render budget needs at least 1 render, got {budget}")
    if objective not in OBJECTIVES:
        raise VtoError(f"unknown objective '{objective}'; choose from {', '.join(OBJECTIVES)}")
    distance = OBJECTIVES[objective]
    start = np.asarray(start, np.float64)
    wraps = np.zeros(start.shape, bool) if wraps is None else np.asarray(wraps, bool)
    start = into_box(start, wraps)
    if held:
        free = np.array([i not in held for i in range(start.size)])
        if not free.any():
            raise VtoError("render search has no free parameter: every one is held")
        pinned = start.copy()
        pinned[list(held)] = list(held.values())

        def render_free(unit_free: np.ndarray) -> np.ndarray:
            unit = pinned.copy()
            unit[free] = unit_free
            return render_unit(unit)

        found = yield from iter_refine_by_render(render_free, reference, start[free], budget, seed, wraps[free],
                                                 objective, sigma)
        unit = start.copy()
        unit[free] = found.unit
        return Refined(unit, found.loss, found.start_loss, found.renders)
    best_unit, best_loss = start, distance(render_unit(start), reference)
    start_loss, renders = best_loss, 1
    yield renders
    if budget == 1:
        return Refined(best_unit, float(best_loss), float(start_loss), renders)
    strategy = cma.CMAEvolutionStrategy(start.tolist(), sigma, {
        "bounds": [[None if w else 0.0 for w in wraps], [None if w else 1.0 for w in wraps]],
        "seed": seed + 1, "verbose": -9, "verb_log": 0, "verb_disp": 0,
        "popsize": max(4, min(4 + int(3 * np.log(start.size)), (budget - 1) // 3))})
    while renders < budget and not strategy.stop():
        asked = strategy.ask()
        left = budget - renders
        candidates = [into_box(x, wraps) for x in asked[:left]]
        losses = []
        for candidate in candidates:
            losses.append(distance(render_unit(candidate), reference))
            yield renders + len(losses)
        renders += len(candidates)
        if len(candidates) == len(asked):
            strategy.tell(asked, losses)
        k = int(np.argmin(losses))
        if losses[k] < best_loss:
            best_unit, best_loss = candidates[k], losses[k]
    return Refined(best_unit, float(best_loss), float(start_loss), renders)
