"""Visibility along a parameter's range: equal unit steps of a saturating parameter show less and less."""

import numpy as np
import pytest

from vto_core.specs import ParamSpec
from vto_core.visibility import parameter_visibility, step_visibility

PARAM = ParamSpec("gloss", "Gloss", 0.0, 1.0, 0.0)


def fake_render(response):
    """A 16x16 render whose value is response(gloss), plus seeded noise of std 0.01."""
    def render(values, seed):
        noise = np.random.default_rng(seed).normal(0.0, 0.01, (16, 16, 3))
        return np.full((16, 16, 3), response(values["gloss"])) + noise
    return render


def test_a_linear_response_is_equally_visible_along_the_range():
    ratios = step_visibility(fake_render(lambda g: 0.2 * g), PARAM, {})
    assert len(ratios) == 4 and max(ratios) / min(ratios) == pytest.approx(1.0, rel=0.05)


def test_a_saturating_response_shows_its_top_steps_less():
    ratios = step_visibility(fake_render(lambda g: 0.2 * (1 - np.exp(-6 * g))), PARAM, {})
    assert ratios == sorted(ratios, reverse=True) and ratios[0] > 5 * ratios[-1]


def test_the_quartile_step_lies_between_its_neighbours():
    """parameter_visibility's 25->75 % change spans the middle two steps of step_visibility."""
    render = fake_render(lambda g: 0.2 * g)
    middle = step_visibility(render, PARAM, {}, points=(0.25, 0.75))[0]
    assert middle == pytest.approx(parameter_visibility(render, PARAM, {}))


def test_a_step_the_render_cannot_show_reads_about_one():
    assert step_visibility(fake_render(lambda g: 0.5), PARAM, {}, points=(0.0, 1.0))[0] == pytest.approx(1.0, rel=0.2)
