"""Renderer speed and noise: ms per render at 64/128/256 px for several sample counts, PSNR between seeds."""

from __future__ import annotations

import os

from benchmarks.common import best_time, write_table
from blender_addon.hair import render_hair_source, run_hair_stage
from blender_addon.lipstick import render_lipstick
from vto_core.metrics import psnr
from vto_core.presets import load_presets

SIZES = (64, 128, 256)
SAMPLES = (4, 16, 64)


def main() -> None:
    """Measure both renderers; writes benchmarks/results/render.md."""
    lip_values = load_presets("lipstick")["Classic Red"]
    hair_values = load_presets("hair")["Copper Red"]
    rows = []
    for res in SIZES:
        for samples in SAMPLES:
            lip_ms = 1000 * best_time(lambda: render_lipstick(lip_values, 1, res, samples), 2)
            lip_noise = psnr(render_lipstick(lip_values, 1, res, samples, 0), render_lipstick(lip_values, 1, res, samples, 1))
            source_ms = 1000 * best_time(lambda: render_hair_source(1, res, samples), 2)
            sources = [render_hair_source(1, res, samples, seed) for seed in (0, 1)]
            stage_ms = 1000 * best_time(lambda: run_hair_stage(sources[0], hair_values), 3)
            hair_noise = psnr(*(run_hair_stage(s, hair_values) for s in sources))
            rows.append([res, samples, f"{lip_ms:.0f}", f"{lip_noise:.1f}", f"{source_ms:.0f}", f"{stage_ms:.1f}",
                         f"{hair_noise:.1f}"])
    write_table(
        "render", "Renderer speed and render noise (Cycles CPU, 2 cores)",
        ["px", "samples", "lipstick ms", "lipstick PSNR seed0/seed1 dB", "hair source ms", "hair stage ms (2 compositor passes)",
         "hair PSNR seed0/seed1 dB"],
        rows,
        f"Reproduce: `make bench` or `.venv/bin/python -m benchmarks.bench_render`. Threads: {os.cpu_count()}. "
        "PSNR between renders with Cycles seeds 0 and 1 measures render noise: higher is cleaner. "
        "The hair stage itself is deterministic; its noise comes from the Cycles source render.",
    )


if __name__ == "__main__":
    main()
