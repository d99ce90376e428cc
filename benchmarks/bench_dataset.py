"""Dataset pipeline throughput against bare bpy.ops.render.render in the same run, and RSS over 2,000 renders."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import write_table

SAMPLES_PER_CONFIG = 24
RSS_RENDERS = 2000


def bare_seconds_per_sample(renderer: str, res: int, repeats: int = 10) -> float:
    """bpy.ops.render.render alone (no file, no readback) for the renders one sample needs."""
    import bpy

    from blender_addon.renderers.hair import COLOR_GROUP, SWATCH_GROUP, _pass_scene, render_hair_source, run_hair_stage
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.renderers.cycles import _quiet_stdout, configure_cycles
    from blender_addon.renderers.scene_hair import build_hair_scene
    from blender_addon.renderers.scene_lips import build_lips_scene

    if renderer == "lipstick":
        render_lipstick({}, 1, res, 16)
        scenes = [(build_lips_scene(), False)] * 2  # X at opacity 0, then R(X, g)
    else:
        run_hair_stage(render_hair_source(1, res, 16), {})
        configure_cycles(build_hair_scene(), res, 16)
        scenes = [(build_hair_scene(), False), (_pass_scene(SWATCH_GROUP), True), (_pass_scene(COLOR_GROUP), True)]
    total = 0.0
    for scene, _ in scenes:
        with bpy.context.temp_override(scene=scene), _quiet_stdout():
            bpy.ops.render.render(scene=scene.name)
            start = time.perf_counter()
            for _ in range(repeats):
                bpy.ops.render.render(scene=scene.name)
            total += (time.perf_counter() - start) / repeats
    return total


def pipeline_seconds_per_sample(renderer: str, res: int, workers: int) -> float:
    """The whole `vto dataset` command, process starts included."""
    out = Path(tempfile.mkdtemp(prefix="vto-bench-"))
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "vto_core.cli", "dataset", renderer, "--out", str(out), "--res", str(res),
                    "--samples", "16", "--quiet", "--workers", str(workers), "--n", str(SAMPLES_PER_CONFIG)],
                   check=True, capture_output=True)
    elapsed = time.perf_counter() - start
    shutil.rmtree(out)
    return elapsed / SAMPLES_PER_CONFIG


def in_process_seconds_per_sample(renderer: str, res: int) -> float:
    """run_in_process in this Python, after one warm-up sample (no process start at all)."""
    from blender_addon.datasets.dataset import DatasetJob, prepare_output, run_in_process

    out = Path(tempfile.mkdtemp(prefix="vto-bench-"))
    job = DatasetJob(renderer, str(out), SAMPLES_PER_CONFIG + 1, res=res)
    prepare_output(job)
    run_in_process(job, range(1), quiet=True)
    start = time.perf_counter()
    run_in_process(job, range(1, SAMPLES_PER_CONFIG + 1), quiet=True)
    elapsed = time.perf_counter() - start
    shutil.rmtree(out)
    return elapsed / SAMPLES_PER_CONFIG


def rss_over_renders(renderer: str) -> tuple[float, float, float]:
    """RSS (MB) of one `vto dataset` process after 100 renders, at the end, and the peak, over RSS_RENDERS renders."""
    per_sample = 2
    out = Path(tempfile.mkdtemp(prefix="vto-bench-rss-"))
    process = subprocess.Popen([sys.executable, "-m", "vto_core.cli", "dataset", renderer, "--out", str(out), "--n",
                                str(RSS_RENDERS // per_sample), "--res", "64", "--samples", "4", "--quiet"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    readings = []  # (renders done, rss MB)
    while process.poll() is None:
        try:
            status = Path(f"/proc/{process.pid}/status").read_text()
            rss = int(next(line for line in status.splitlines() if line.startswith("VmRSS")).split()[1]) / 1024
            done = len(list((out / "samples").glob("0*"))) * per_sample
            readings.append((done, rss))
        except (FileNotFoundError, StopIteration):
            pass
        time.sleep(0.5)
    shutil.rmtree(out)
    after_warmup = next(rss for done, rss in readings if done >= 100)
    return after_warmup, readings[-1][1], max(rss for _, rss in readings)


def main() -> None:
    """Writes benchmarks/results/dataset.md."""
    rows = []
    for renderer in ("lipstick", "hair"):
        for res in (64, 128):
            bare = bare_seconds_per_sample(renderer, res)
            here = in_process_seconds_per_sample(renderer, res)
            one = pipeline_seconds_per_sample(renderer, res, 1)
            two = pipeline_seconds_per_sample(renderer, res, 2)
            renders = 2 if renderer == "lipstick" else 3
            rows.append([renderer, res, f"{1000 * bare:.0f}", f"{1000 * here:.0f}", f"{100 * (here / bare - 1):+.1f}%",
                         f"{renders / one:.1f}", f"{renders / two:.1f}", f"{one / two:.2f}"])
    memory = [[renderer, RSS_RENDERS, *(f"{v:.0f}" for v in rss_over_renders(renderer))] for renderer in ("lipstick", "hair")]
    write_table(
        "dataset", "Dataset pipeline vs bare rendering (16 samples per pixel, no sensitivity)",
        ["renderer", "px", "bare render ms/sample", "pipeline ms/sample", "pipeline overhead", "renders/s 1 worker",
         "renders/s 2 workers", "speed-up"],
        rows,
        "A lipstick sample is 2 Cycles renders (X at opacity 0, R(X, g)); a hair sample is 1 Cycles render + 2 "
        "compositor passes (counted as 3 renders). Bare = `bpy.ops.render.render` without writing, same scenes, "
        "same run. Pipeline = `run_in_process` (render + EXR readback + 16-bit PNG writes + params.json + rename). "
        "Worker columns time the whole `vto dataset` command, Blender start-up of each process included "
        f"({SAMPLES_PER_CONFIG} samples). Target: overhead <= 15%.\n\n"
        "## Memory over a long run\n\n| renderer | renders | RSS after 100 renders MB | RSS at the end MB | peak MB |\n"
        "|---|---|---|---|---|\n" + "\n".join("| " + " | ".join(str(c) for c in row) + " |" for row in memory)
        + "\n\nTarget: growth under 50 MB. Reproduce: `.venv/bin/python -m benchmarks.bench_dataset`.",
    )


if __name__ == "__main__":
    main()
