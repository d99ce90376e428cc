"""Which parameters a render can show: a quartile change of one parameter against render noise."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .metrics import visibility_ratio
from .specs import ParamSpec

VISIBLE_RATIO = 3.0  # the change must stand this far above seed-to-seed noise (4x4 block means)
# The look each parameter is measured on: the renderer's defaults, lipstick fully on; inputs that only act on a
# layer get that layer (flakes for the sparkle inputs, a glossy coat, gloss at its 75th percentile, for its roughness).
_LOOKS = {"lipstick": {"opacity": 1.0}, "hair": {}}
# Modelled by default although below the bar (measured on the looks below, 64 px, default samples): the encoder
# can still learn them from the whole lips or hair, but not every 4x4 block shows them. `vto spec` names them.
BELOW_BAR = {
    "lipstick": {},
    "hair": {},
}
_CONTEXT = {"sparkle": {"sparkle_density": 0.5, "sparkle_intensity": 0.75}, "gloss_roughness": {"gloss": 2.0}}


def below_bar(renderer: str) -> dict[str, str]:
    """The modelled parameters that stay under VISIBLE_RATIO, each with its measured ratio and why."""
    return {name: f"visibility {ratio:.2f} < {VISIBLE_RATIO:g}: {why}" for name, (ratio, why) in
            BELOW_BAR.get(renderer, {}).items()}


def measurement_look(renderer: str, name: str) -> dict[str, float]:
    """The parameter values (besides `name`) a visibility measurement of `name` starts from."""
    context = next((values for prefix, values in _CONTEXT.items() if name.startswith(prefix)), {})
    return {**_LOOKS[renderer], **(context if renderer == "lipstick" else {})}


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
