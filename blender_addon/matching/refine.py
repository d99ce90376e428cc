"""Refinement through the real renderer, with an exact render budget: a Gauss-Newton fit of the render to the
reference (squared differences), or a derivative-free CMA-ES search (any objective).

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
SEARCHES = ("fit", "cma")  # fit: Gauss-Newton on squared differences (mse only); cma: CMA-ES
DIFFERENCE_STEP = 0.03  # the fit's finite-difference step in unit space: its change stands well above the noise
MAX_STEP = 0.5  # the fit moves no parameter further than this in one step


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
                     held: dict[int, float] | None = None, search: str = "fit") -> Refined:
    """Refinement to the end: see iter_refine_by_render."""
    return drain(iter_refine_by_render(render_unit, reference, start, budget, seed, wraps, objective, sigma, held,
                                       search))


def iter_refine_by_render(render_unit: Callable[[np.ndarray], np.ndarray], reference: np.ndarray, start: np.ndarray,
                          budget: int, seed: int = 0, wraps=None, objective: str = "mse", sigma: float = SIGMA,
                          held: dict[int, float] | None = None, search: str = "fit"):
    """Minimise objective(render_unit(u), reference) over u in [0, 1]^m from `start`, with at most `budget` renders.

    render_unit: (m,) unit vector -> (H, W, 3) image like `reference`; wraps: (m,) bool, dimensions that wrap (hue).
    held: {dimension: unit value} rendered at that value and left out of the search; the result keeps the start's
    values there (see blender_addon.renderers.hair.own_source_held for why).
    search: "fit" (iter_fit, the default; the mse objective only; a budget under m + 2 renders goes to CMA-ES) or
    "cma" (iter_cma_search; sigma is its first step).
    The start is rendered first and kept unless something renders closer, so the result is never worse than the
    start on this objective.

    A generator: it yields the renders made so far after each render (so a modal operator can run it a few renders
    per timer tick, and show progress) and returns the Refined result (StopIteration.value).
    """
    if budget < 1:
        raise VtoError(f"a render budget needs at least 1 render, got {budget}")
    if objective not in OBJECTIVES:
        raise VtoError(f"unknown objective '{objective}'; choose from {', '.join(OBJECTIVES)}")
    if search not in SEARCHES:
        raise VtoError(f"unknown render search '{search}'; choose from {', '.join(SEARCHES)}")
    if search == "fit" and objective != "mse":
        raise VtoError(f"the fit minimises squared differences (objective mse); the {objective} objective needs "
                       "the cma search")
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
                                                 objective, sigma, search=search)
        unit = start.copy()
        unit[free] = found.unit
        return Refined(unit, found.loss, found.start_loss, found.renders)
    if search == "fit" and budget >= start.size + 2:  # a smaller budget has no room for a Jacobian and a step
        return (yield from iter_fit(render_unit, reference, start, budget, wraps))
    return (yield from iter_cma_search(render_unit, reference, start, budget, seed, wraps, OBJECTIVES[objective],
                                       sigma))


def iter_fit(render_unit: Callable[[np.ndarray], np.ndarray], reference: np.ndarray, start: np.ndarray,
             budget: int, wraps: np.ndarray, step: float = DIFFERENCE_STEP):
    """Levenberg-Marquardt on the pixel differences render_unit(u) - reference, inside the unit box.

    The first Jacobian (m,) costs m renders (forward differences, inward at the box's upper side); each step after it
    costs one render and updates the Jacobian by Broyden's rank-one rule from what that render showed; after two
    failed steps in a row the Jacobian is measured again where the budget has room for it. A budget smaller than
    m + 2 renders stops after the start's render (iter_refine_by_render gives such budgets to CMA-ES instead).
    On one Cycles seed a changed material also changes the noise a little (other light paths are sampled), so the
    differences are taken over a step well above that, and a step is kept only if it renders closer. A parameter
    the render does not show gets a zero column, which the damping keeps still.
    Generator as iter_refine_by_render; returns Refined.
    """
    reference = np.asarray(reference, np.float64)

    def residual(unit: np.ndarray) -> np.ndarray:
        return (np.asarray(render_unit(unit), np.float64) - reference).ravel()

    unit, differences = start, residual(start)
    loss = start_loss = float(np.mean(differences**2))
    renders, jacobian, damping, failures = 1, None, 1e-2, 0
    yield renders
    while renders < budget:
        if jacobian is None:
            if renders + start.size >= budget:  # no room for a Jacobian and a step after it
                break
            jacobian = np.empty((differences.size, start.size))
            for j in range(start.size):
                h = -step if (unit[j] + step > 1.0 and not wraps[j]) else step
                probe = unit.copy()
                probe[j] += h
                jacobian[:, j] = (residual(into_box(probe, wraps)) - differences) / h
                renders += 1
                yield renders
        gram = jacobian.T @ jacobian
        scale = np.diag(gram) + 1e-9 * max(float(np.diag(gram).max()), 1e-12)
        move = -np.linalg.solve(gram + damping * np.diag(scale), jacobian.T @ differences)
        move *= min(1.0, MAX_STEP / max(float(np.abs(move).max()), 1e-12))
        trial = into_box(unit + move, wraps)
        trial_differences = residual(trial)
        renders += 1
        yield renders
        taken = trial - unit
        if np.dot(taken, taken) > 0:  # Broyden: the Jacobian now explains the step it just saw
            jacobian += np.outer(trial_differences - differences - jacobian @ taken, taken) / np.dot(taken, taken)
        trial_loss = float(np.mean(trial_differences**2))
        if trial_loss < loss:
            unit, differences, loss = trial, trial_differences, trial_loss
            damping, failures = max(damping / 3.0, 1e-6), 0
        else:
            damping, failures = min(damping * 4.0, 1e6), failures + 1
            if failures >= 2 and renders + start.size < budget:  # else go on with the updated one to the end
                jacobian, failures = None, 0
    return Refined(unit, loss, start_loss, renders)


def iter_cma_search(render_unit: Callable[[np.ndarray], np.ndarray], reference: np.ndarray, start: np.ndarray,
                    budget: int, seed: int, wraps: np.ndarray, distance: Callable, sigma: float = SIGMA):
    """CMA-ES on distance(render_unit(u), reference) from `start` with first step `sigma`. Whole generations are told
    back; what is left of the budget at the end is spent on part of one more generation (evaluated, kept if better,
    not told), so exactly `budget` renders are made unless the search converges first. Generator as
    iter_refine_by_render; returns Refined."""
    import cma

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


def drain(steps, progress: Callable[[int], None] | None = None):
    """Run a generator to its end, passing each yielded count to `progress`; its return value."""
    while True:
        try:
            done = next(steps)
        except StopIteration as finished:
            return finished.value
        if progress is not None:
            progress(done)
