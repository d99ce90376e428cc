"""Which parameters a product's 64 px default render can show: each one's 25th -> 75th percentile change against render
noise (vto_core.visibility.parameter_visibility, 4x4 blocks of the product's region), on default sources 1-4.

    python -m benchmarks.bench_parameter_visibility [--renderer eyeshadow] [--sources 4]

Each parameter is measured on its measurement look (vto_core.visibility.measurement_look: the product on, with the
layer it acts on). The bar is VISIBLE_RATIO (3): every modelled parameter must stand above it (a parameter under it
is left out of the spec, which names why: `vto spec`'s "left_out"). Writes the '<renderer>-parameters' section of
benchmarks/results/visibility.md.
"""

from __future__ import annotations

import argparse

import numpy as np

from benchmarks.common import table, write_section


def main(argv: list[str] | None = None) -> None:
    """Measure every parameter of --renderer and write its section of visibility.md."""
    from blender_addon.renderers.products import blender_side
    from vto_core.dataset import DEFAULT_SAMPLES
    from vto_core.products import get_product
    from vto_core.visibility import VISIBLE_RATIO, measurement_look, parameter_visibility

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--renderer", default="eyeshadow")
    parser.add_argument("--sources", type=int, default=4)
    args = parser.parse_args(argv)
    product = get_product(args.renderer)
    sources = range(1, args.sources + 1)
    bound = {source: blender_side(product).bind(source, 64, DEFAULT_SAMPLES, 0) for source in sources}
    rows = []
    for param in product.spec.params:
        look = measurement_look(product.name, param.name)
        ratios = []
        for source, on in bound.items():
            def render(values, seed, source=source):
                return blender_side(product).render(values, source, 64, DEFAULT_SAMPLES, seed)
            ratios.append(parameter_visibility(render, param, look, mask=on.mask))
        mean = float(np.mean(ratios))
        modelled = param.name in product.spec.modelled
        verdict = ("modelled" if modelled else f"left out: {param.unmodelled_reason}")
        rows.append([param.name, f"{param.from_unit(0.25):.3g} -> {param.from_unit(0.75):.3g}",
                     " ".join(f"{r:.2f}" for r in ratios), f"{mean:.2f}",
                     "yes" if mean >= VISIBLE_RATIO else "no", verdict])
        print(rows[-1][:5], flush=True)
    body = (f"Change / seed noise on 4x4 blocks of the {product.region} (`{product.name}`, 64 px, {DEFAULT_SAMPLES} "
            f"spp, default sources {', '.join(map(str, sources))}); each parameter moved from its 25th to its 75th "
            f"percentile on its measurement look. The bar is {VISIBLE_RATIO:g}.\n\n"
            + table(["parameter", "25th -> 75th", "each source", "mean", f">= {VISIBLE_RATIO:g}", "in the spec"], rows)
            + f"\n\nReproduce: `python -m benchmarks.bench_parameter_visibility --renderer {product.name}`.")
    write_section("visibility", f"{product.name}-parameters",
                  f"## Which {product.label.lower()} parameters a 64 px default render shows\n\n{body}")


if __name__ == "__main__":
    main()
