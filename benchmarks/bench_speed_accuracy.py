"""The speed-accuracy trade at match time, measured in one run: presets, encoder, render-search refinement."""

from __future__ import annotations

import os
import platform
import sys
import tempfile
from pathlib import Path

from benchmarks.common import RESULTS, write_table
from blender_addon.evaluate import EvalSettings, run_eval

MODEL = Path(__file__).resolve().parent.parent / "blender_addon" / "models" / "lipstick_encoder.onnx"


def main(model: str = str(MODEL), n: int = 8) -> None:
    """Transfer PSNR/SSIM and wall ms per reference of each method; writes speed_accuracy.md and .png."""
    with tempfile.TemporaryDirectory() as folder:
        summary = run_eval(model, folder, EvalSettings(n=n, refine=(25, 100), search_from_mean=(400,)))
    rows = sorted(([m, f"{s['ms_per_reference']:.0f}", f"{s['psnr_mean']:.2f}", f"{s['ssim_mean']:.4f}"]
                   for m, s in summary.items()), key=lambda row: float(row[1]))
    cpu = platform.processor() or platform.machine()
    write_table("speed_accuracy", "Match-time speed and accuracy (transfer experiment, 64 px, 16 spp)",
                ["method", "ms per reference", "transfer PSNR dB", "SSIM"], rows,
                f"{n} sampled looks, model {Path(model).name}; {cpu}, {os.cpu_count()} cores, Cycles on the CPU. "
                "Nearest preset includes rendering every preset on the reference's source. "
                "Reproduce: `.venv/bin/python -m benchmarks.bench_speed_accuracy [MODEL] [N]`.")
    _plot(summary)


def _plot(summary: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = sorted((max(s["ms_per_reference"], 0.01), s["psnr_mean"], m) for m, s in summary.items())
    front, best = [], float("-inf")
    for ms, psnr, _ in points:
        if psnr > best:
            front.append((ms, psnr))
            best = psnr
    figure, axis = plt.subplots(figsize=(6.5, 4))
    for ms, psnr, name in points:
        axis.scatter(ms, psnr)
        axis.annotate(name, (ms, psnr), fontsize=7, xytext=(4, 2), textcoords="offset points")
    axis.plot(*zip(*front), "k--", linewidth=0.8, label="Pareto front")
    axis.set_xscale("log")
    axis.set_xlabel("wall ms per reference (log)")
    axis.set_ylabel("transfer PSNR (dB)")
    axis.legend()
    figure.tight_layout()
    figure.savefig(RESULTS / "speed_accuracy.png", dpi=110)
    plt.close(figure)


if __name__ == "__main__":
    main(*(sys.argv[1:2] or [str(MODEL)]), *([int(sys.argv[2])] if len(sys.argv) > 2 else []))
