"""How visible each step of an encoded lipstick parameter is along its range (issue: equal steps, equal visibility).

For opacity, gloss and reflection: the visibility ratio (vto_core.visibility.step_visibility: change / seed noise
on 4x4 blocks of the lips, 64 px, default samples) of each quarter of the unit range, on the parameter's usual
measurement look, on default sources 1-4 under the default lighting; the mean over sources per step.

    python -m benchmarks.bench_visibility [--sources 4]
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.common import table, write_section

PARAMS = ("opacity", "gloss", "reflection")
POINTS = (0.0, 0.25, 0.5, 0.75, 1.0)


def main() -> None:
    """Measure and write the 'visibility-steps' section of benchmarks/results/visibility.md."""
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.renderers.scene_build import DEFAULT_LIGHTING
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.dataset import DEFAULT_SAMPLES
    from vto_core.products import get_spec
    from vto_core.visibility import measurement_look, step_visibility

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sources", type=int, default=4)
    args = parser.parse_args()
    spec = get_spec("lipstick")
    rows = []
    for name in PARAMS:
        param = spec.by_name[name]
        per_source = []
        for source in range(1, 1 + args.sources):
            def render(values, seed, source=source):
                return render_lipstick(values, source, 64, DEFAULT_SAMPLES, seed)
            per_source.append(step_visibility(render, param, measurement_look("lipstick", name), POINTS,
                                              mask=lips_mask(source, 64)))
        means = np.mean(per_source, axis=0)
        raw = [f"{param.from_unit(u):.3g}" for u in POINTS]
        rows.append([name, " → ".join(raw), *[f"{m:.2f}" for m in means]])
        print(name, means.round(2).tolist(), flush=True)
    steps = [f"{a:g}→{b:g}" for a, b in zip(POINTS, POINTS[1:])]
    write_section("visibility", "visibility-steps", (
        f"## Visibility of each quarter of the encoded range ({DEFAULT_LIGHTING} lighting, 64 px)\n\n"
        f"Change / seed noise on 4x4 blocks of the lips for each step of the unit range (1 = lost in noise, the bar "
        f"is 3), mean over default sources 1-{args.sources}; the raw values at the step ends in the second column.\n\n"
        + table(["parameter", "raw values at unit 0, .25, .5, .75, 1", *[f"unit {s}" for s in steps]], rows)
        + "\n\nReproduce: `python -m benchmarks.bench_visibility`."))


if __name__ == "__main__":
    main()
