"""Renderer speed, noise, clamp bias and parameter visibility at the dataset's default settings."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import best_time, write_table
from blender_addon.renderers.hair import render_hair_source, run_hair_stage
from blender_addon.renderers.product_lipstick import render_lipstick
from blender_addon.renderers.cycles import render_passes, to_display
from blender_addon.renderers.scene_furnace import render_furnace, seen_colour
from blender_addon.renderers.scene_lips import build_lips_scene, lips_mask
from vto_core.colour import linear_to_srgb, srgb_to_linear
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.metrics import psnr
from vto_core.presets import load_presets, preset_matrix
from vto_core.sampling import ParamSampler
from vto_core.products import get_spec
from vto_core.visibility import measurement_look, parameter_visibility

SIZES = (64, 128, 256)
SOURCES = (1, 2, 3, 4)
# The renderer before the energy-conserving layer, env lights and denoiser: 16 spp, additive gloss, every
# sample clamped at 1. Timed in the same run from a git worktree of that commit, alternating with this tree,
# each in its own process, best of the rounds (so a busy moment does not favour either).
BEFORE_REV = "fd609b2"
ROUNDS = 2
LIPSTICK_SCRIPT = """
import json, sys, time
import numpy as np
from blender_addon.renderers.product_lipstick import render_lipstick
from vto_core.metrics import psnr
from vto_core.presets import load_presets
values = load_presets("lipstick")["Classic Red"]
out = {}
for res in %r:
    render_lipstick(values, 1, res, 16)
    times = []
    for seed in range(3):
        start = time.perf_counter(); render_lipstick(values, 1, res, 16, seed); times.append(time.perf_counter() - start)
    noise = np.mean([psnr(render_lipstick(values, s, res, 16, 0), render_lipstick(values, s, res, 16, 1)) for s in %r])
    out[res] = (1000 * min(times), float(noise))
print("RESULT", json.dumps(out))
"""


def _lipstick_timings(tree: str) -> dict[int, tuple[float, float]]:
    """{res: (ms, PSNR dB)} of the lipstick renderer of the source tree `tree`, in a fresh process."""
    done = subprocess.run([sys.executable, "-c", LIPSTICK_SCRIPT % (SIZES, SOURCES)], cwd=tree, check=True,
                          capture_output=True, text=True)
    line = next(row for row in done.stdout.splitlines() if row.startswith("RESULT "))
    return {int(k): tuple(v) for k, v in json.loads(line[len("RESULT "):]).items()}


def before_and_after() -> tuple[dict, dict]:
    """Lipstick {res: (ms, dB)} of BEFORE_REV and of this tree, alternating rounds, best time of each."""
    here = str(Path(__file__).resolve().parent.parent)
    results = {"before": [], "after": []}
    with tempfile.TemporaryDirectory() as folder:
        tree = os.path.join(folder, "before")
        subprocess.run(["git", "worktree", "add", "--detach", "-q", tree, BEFORE_REV], check=True, cwd=here)
        try:
            for _ in range(ROUNDS):
                results["before"].append(_lipstick_timings(tree))
                results["after"].append(_lipstick_timings(here))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", tree], check=True, cwd=here)
    return tuple({res: (min(r[res][0] for r in rounds), rounds[0][res][1]) for res in SIZES}
                 for rounds in (results["before"], results["after"]))


def speed_and_noise() -> list[list]:
    """ms per render and seed-to-seed PSNR, both renderers, at the default samples."""
    hair_values = load_presets("hair")["Copper Red"]
    rows = []
    old, new = before_and_after()
    for res in SIZES:
        lip_ms, lip_noise = new[res]
        source_ms = 1000 * best_time(lambda: render_hair_source(1, res, DEFAULT_SAMPLES), 2)
        hair_noise = np.mean([psnr(*(run_hair_stage(render_hair_source(s, res, DEFAULT_SAMPLES, seed), hair_values)
                                     for seed in (0, 1))) for s in SOURCES])
        rows.append([res, DEFAULT_SAMPLES, f"{lip_ms:.0f}", f"{lip_noise:.1f}", f"{old[res][0]:.0f} / {old[res][1]:.1f}",
                     f"{source_ms:.0f}", f"{hair_noise:.1f}"])
    return rows


def clamp_bias() -> list[list]:
    """Mean change of the lips a sample clamp causes, against an unclamped render (256 spp, no denoiser)."""
    scene = build_lips_scene()
    rows = []
    values = load_presets("lipstick")["Cherry Gloss"]
    for source in SOURCES:
        mask = lips_mask(source, 64)
        images = {}
        for name, (direct, indirect) in {"none": (0.0, 0.0), "indirect 1 (now)": (0.0, 1.0),
                                         "direct+indirect 1 (before)": (1.0, 1.0)}.items():
            render_lipstick(values, source, 64, 1)  # sets the scene up for this source
            scene.cycles.samples, scene.cycles.use_denoising = 256, False
            scene.cycles.sample_clamp_direct, scene.cycles.sample_clamp_indirect = direct, indirect
            images[name] = to_display(render_passes(scene)["Combined"][..., :3])
        hdri = scene.world.node_tree.nodes["HDRI"].image.name.removeprefix("VTO HDRI ")
        rows.append([source, hdri] + [f"{255 * (images[k][mask] - images['none'][mask]).mean():+.1f}"
                                      for k in ("indirect 1 (now)", "direct+indirect 1 (before)")])
    return rows


def visibility() -> list[list]:
    """visibility_ratio of every parameter: the test's look, and the mean over four sampled looks."""
    rows = []
    lip_spec, hair_spec = get_spec("lipstick"), get_spec("hair")
    sampler = ParamSampler(lip_spec, preset_matrix(lip_spec, load_presets("lipstick")), 0.5, seed=2024)
    looks = [lip_spec.values(sampler.sample(i)) for i in range(4)]
    for param in lip_spec.params:
        test_look = measurement_look("lipstick", param.name)
        extra = {k: v for k, v in test_look.items() if k != "opacity"}  # the layer the parameter acts on
        ratios = []
        for index, look in enumerate([test_look] + looks):
            source = 1 + index

            def render(values, seed, source=source):
                return render_lipstick(values, source, 64, DEFAULT_SAMPLES, seed)
            ratios.append(parameter_visibility(render, param, {**look, **extra}, mask=lips_mask(source, 64)))
        rows.append(["lipstick", param.name, "yes" if param.name in lip_spec.modelled else "no",
                     f"{ratios[0]:.2f}", f"{np.mean(ratios[1:]):.2f}"])
    sources = {seed: render_hair_source(1, 64, DEFAULT_SAMPLES, seed) for seed in (0, 1)}
    for param in hair_spec.params:
        ratio = parameter_visibility(lambda v, s: run_hair_stage(sources[s], v), param,
                                     measurement_look("hair", param.name), mask=sources[0].mask)
        rows.append(["hair", param.name, "yes" if param.name in hair_spec.modelled else "no", f"{ratio:.2f}", ""])
    return rows


def colour_fidelity() -> list[list]:
    """Each preset, opaque and without mirror reflection, in the white furnace: set vs seen colour, 8-bit sRGB.

    Seen = set x (1 - s) + s in linear light for a white (Fresnel) share s; the last column is what that model leaves
    unexplained, in 8-bit sRGB steps (0 = the viewer sees exactly the set colour under a white coat).
    """
    rows = []
    for name, values in load_presets("lipstick").items():
        rgb = np.array([values["red"], values["green"], values["blue"]])
        linear, sphere = render_furnace({**values, "opacity": 1.0, "reflection": 0.0}, samples=64)
        seen, white, _ = seen_colour(linear, sphere, rgb)
        modelled = srgb_to_linear(rgb / 255) * (1 - white) + white
        off = np.abs(linear_to_srgb(seen) - linear_to_srgb(modelled)).max() * 255
        rows.append([name, f"{values['gloss']:g}", " ".join(str(int(c)) for c in rgb.round()),
                     " ".join(str(int(c)) for c in (linear_to_srgb(seen) * 255).round()), f"{white:.3f}", f"{off:.1f}"])
    return rows


def main() -> None:
    """Measure both renderers; writes benchmarks/results/render.md."""
    sections = [
        ("Speed and render noise", ["px", "spp", "lipstick ms", "lipstick PSNR seed 0/1 dB",
                                    f"lipstick before ({BEFORE_REV}, 16 spp, no denoiser): ms / dB", "hair source ms",
                                    "hair PSNR seed 0/1 dB"], speed_and_noise()),
        ("Sample-clamp bias on the lips (mean, 1/255 units; Cherry Gloss, 64 px, 256 spp)",
         ["source", "HDRI", "clamp indirect at 1 (now)", "clamp all at 1 (before)"], clamp_bias()),
        ("Parameter visibility: 25th->75th percentile change / seed noise, 4x4 blocks on the lips or hair, 64 px",
         ["renderer", "parameter", "modelled by default", "test look (defaults, opacity 1, + the layer it acts on)", "mean of 4 sampled looks"],
         visibility()),
        ("Colour fidelity: each preset opaque, no mirror, white furnace (32 px, 64 spp, unclamped)",
         ["preset", "gloss", "set sRGB", "seen sRGB (median)", "white share", "off the set colour beyond it (/255)"],
         colour_fidelity()),
    ]
    notes = (f"Reproduce: `.venv/bin/python -m benchmarks.bench_render`. Threads: {os.cpu_count()}. Renders are "
             f"{DEFAULT_SAMPLES} spp with OpenImageDenoise (RGB+albedo+normal, fast prefilter); PSNR averaged over "
             f"sources {SOURCES}. A visibility ratio of 1 means the change is lost in noise; the bar is 3.")
    header, *rest = sections
    write_table("render", "Renderers: speed, noise, clamp bias, visibility (Cycles CPU)", header[1], header[2],
                notes + "\n\n" + "\n\n".join(_markdown(title, cols, rows) for title, cols, rows in rest))


def _markdown(title: str, header: list[str], rows: list[list]) -> str:
    lines = [f"## {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])


if __name__ == "__main__":
    main()
