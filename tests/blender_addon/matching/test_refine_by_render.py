"""Refinement through a renderer (blender_addon.matching.refine) on small numpy renderers: the fit, the CMA-ES search,
budgets."""

import numpy as np
import pytest

from blender_addon.matching.refine import refine_by_render
from vto_core.errors import VtoError
from vto_core.metrics import mse

TRUTH = np.array([0.3, 0.7, 0.55])
GRID = np.linspace(0.0, 1.0, 8)


def smooth_render(unit):
    """A 8x8x3 image that depends smoothly and nonlinearly on three parameters (as opacity mixes a colour in)."""
    x, y = np.meshgrid(GRID, GRID)
    a, b, c = unit
    red = a * b + 0.2 * np.sin(3 * x) * c
    green = (1 - a) * 0.4 + a * c**2 + 0.1 * y
    blue = 0.5 * b * y + 0.3 * c * x
    return np.stack([red, green, blue], axis=-1).astype(np.float32)


def counting(render):
    """render wrapped to count and remember its calls."""
    seen = []

    def wrapped(unit):
        seen.append(np.array(unit))
        return render(unit)

    return wrapped, seen


def test_the_fit_finds_the_truth_of_a_smooth_renderer_where_cma_es_gets_near():
    reference = smooth_render(TRUTH)
    start = TRUTH + np.array([0.15, -0.2, 0.12])
    fit = refine_by_render(smooth_render, reference, start, 30, search="fit")
    cma = refine_by_render(smooth_render, reference, start, 30, search="cma")
    assert np.abs(fit.unit - TRUTH).max() < 1e-3
    assert fit.loss < 1e-6 < cma.loss < cma.start_loss


@pytest.mark.parametrize("budget", [5, 6, 13])
def test_the_fit_spends_its_budget_exactly_stays_in_the_box_and_never_worsens(budget):
    render, seen = counting(smooth_render)
    reference = smooth_render(np.array([1.0, 0.0, 0.9]))  # at the box's edges: steps must be clipped
    refined = refine_by_render(render, reference, np.full(3, 0.5), budget)
    assert refined.renders == budget == len(seen)  # 1 start + 3 differences + at least 1 step
    assert all(((0 <= u) & (u <= 1)).all() for u in seen)
    assert refined.loss == pytest.approx(mse(smooth_render(refined.unit), reference))
    assert refined.loss < refined.start_loss


def test_a_budget_without_room_for_the_fits_first_step_goes_to_cma_es():
    render, seen = counting(smooth_render)
    start = np.full(3, 0.5)
    refined = refine_by_render(render, smooth_render(TRUTH), start, 4)  # 1 + 3 differences leave no step
    assert refined.renders == 4 == len(seen) and len({tuple(u) for u in seen}) == 4  # CMA-ES's candidates
    assert refined.loss <= refined.start_loss


def test_a_parameter_the_render_does_not_show_stays_where_it_started():
    def render(unit):
        return smooth_render(np.array([unit[0], unit[1], 0.55]))  # the third input is ignored

    refined = refine_by_render(render, smooth_render(TRUTH), np.array([0.5, 0.5, 0.1]), 20)
    assert np.isfinite(refined.unit).all() and refined.unit[2] == pytest.approx(0.1)
    assert np.abs(refined.unit[:2] - TRUTH[:2]).max() < 1e-3


def test_the_fit_keeps_held_dimensions_out():
    render, seen = counting(smooth_render)
    refined = refine_by_render(render, smooth_render(TRUTH), np.array([0.5, 0.5, 0.5]), 15, held={2: 0.55})
    assert all(u[2] == 0.55 for u in seen) and refined.unit[2] == 0.5
    assert np.abs(refined.unit[:2] - TRUTH[:2]).max() < 1e-3


@pytest.mark.parametrize("kwargs, message", [
    ({"search": "fit", "objective": "ssim"}, "cma search"),
    ({"search": "newton"}, "unknown render search"),
    ({"budget": 0}, "at least 1 render"),
])
def test_bad_settings_are_one_line_errors(kwargs, message):
    settings = {"budget": 10, **kwargs}
    with pytest.raises(VtoError, match=message):
        refine_by_render(smooth_render, smooth_render(TRUTH), np.full(3, 0.5), **settings)
