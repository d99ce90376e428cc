"""Every declared product's default-scene render at 64 px and the dataset's samples: ms a render, in one process.

    python -m benchmarks.bench_render_products [--repeats 5]

Each product wears its first preset on sources 1-4; the best of --repeats renders after a warm-up is its time, the
median over the sources the product's figure. The CPU's load average is written beside it: a figure taken beside
another job is an upper bound. Writes benchmarks/results/render_products.md.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from benchmarks.common import best_time, write_table

SOURCES = (1, 2, 3, 4)
SIZE = 64


def main(argv: list[str] | None = None) -> None:
    from blender_addon.renderers.products import render
    from vto_core.dataset import DEFAULT_SAMPLES
    from vto_core.presets import load_presets
    from vto_core.products import PRODUCTS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    load = os.getloadavg()[0]
    rows = []
    for name in PRODUCTS:
        presets = load_presets(name)
        first = next(iter(presets))
        times = [1000 * best_time(lambda source=source: render(name, presets[first], source, SIZE, DEFAULT_SAMPLES, 0),
                                  args.repeats) for source in SOURCES]
        rows.append([name, first, f"{np.median(times):.0f}", " / ".join(f"{t:.0f}" for t in times)])
    write_table("render_products", f"Each product's default-scene render, {SIZE} px, {DEFAULT_SAMPLES} spp",
                ["product", "preset", "median ms", "ms on sources " + ", ".join(map(str, SOURCES))], rows,
                f"Best of {args.repeats} after a warm-up, one process; load average {load:.2f} when it began "
                f"(2 cores; above about 0.5 something else was running). Goal (eye shadow): <= 200 ms.")


if __name__ == "__main__":
    main()
