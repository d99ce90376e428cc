"""How precisely one render of the default lips scene can tell the lipstick's parameters: a floor for any encoder.

For N fresh looks (portrait lighting), on each of K Cycles seeds: the render and its central differences in each
encoded parameter, as means of the lips' blocks. One half of the seeds' differences against the other's gives the
render's information (vto_core.visibility.render_information: a changed parameter also changes the noise, which
must not count as signal), and with the sampler's spread as prior the posterior spread of each parameter
(vto_core.visibility.parameter_floor). Three readers: one that knows the scene (source, light, camera); one that
must also allow for the camera's residual exposure and white-balance error without metering the skin; and one that
does not know the bare lips' own tone either (within what the skin tells of it). From those spreads: the median
colour error (8-bit steps, R, G and B pooled) on the looks with opacity >= 0.5 and the mean absolute error of
opacity, gloss and reflection (unit range) that such an ideal reader would make, at each resolution and sample count
asked for. Noise is taken as independent between blocks, so the floor is optimistic. On the 64 px, default-sample
renders the shipped encoder reads the same references (the last row). Writes the 'render-floor' section of
benchmarks/results/colour_floor.md.

    python -m benchmarks.bench_render_floor [--n 48] [--seed 8101] [--settings 64x16,64x64,128x16] [--seeds 4]
"""

from __future__ import annotations

import argparse
import contextlib
import time
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, lip_colour, table, write_section

COLOUR = ("red", "green", "blue")
OTHERS = ("opacity", "gloss", "reflection")
PRIOR_DRAWS = 20000
TONE_STEP = 0.1  # of the bare lips' tone-shift factor, whose draw is uniform over 0.6-1.3
TONE_PRIOR = 0.7**2 / 12
READERS = {"prior": "no render (the sampler's spread)", "known": "knows the scene",
           "camera": "+ the camera's residual exposure and white balance unknown",
           "tone": "+ the bare lips' tone unknown"}


def pooled_median_error(stds: np.ndarray, draws: int = 400, seed: int = 0) -> float:
    """stds (N, C) of Gaussian errors -> the median |error| over every look, channel and draw."""
    rng = np.random.default_rng(seed)
    return float(np.median(np.abs(rng.normal(size=(draws, *stds.shape)) * stds)))


def camera_prior() -> np.ndarray:
    """(2, 2) covariance of the default camera's residual errors: uniform exposure (stops) and white-balance shift."""
    from vto_core.portrait_light import EXPOSURE_EV, WARM_COOL

    return np.diag([(2 * EXPOSURE_EV) ** 2 / 12, (2 * WARM_COOL) ** 2 / 12])


@contextlib.contextmanager
def lip_tone_shift(offset: float):
    """Renders in this block show the default scene's bare lips `offset` further along their tone shift from the skin
    (scene_lips.LIP_TONE_SHIFT times a factor drawn in 0.6-1.3, the scene's only lip-tone freedom once the skin is
    seen). The source must already be applied; its colour comes back after."""
    import bpy

    from blender_addon.renderers.scene_lips import LIP_TONE_SHIFT, LIPS_MATERIAL
    from vto_core.colour import linear_to_srgb, srgb_to_linear

    socket = bpy.data.materials[LIPS_MATERIAL].node_tree.nodes["Bare Lips"].inputs["Base Color"]
    kept = tuple(socket.default_value)
    tone = np.clip(linear_to_srgb(np.array(kept[:3])) + offset * np.array(LIP_TONE_SHIFT), 0.02, 1.0)
    socket.default_value = (*srgb_to_linear(tone), kept[3])
    try:
        yield
    finally:
        socket.default_value = kept


def measure_look(spec, sampler, prior: np.ndarray, seed: int, index: int, res: int, samples: int,
                 seeds: int) -> dict:
    """Renders of one look: derivatives and noise on `seeds` Cycles seeds -> per-parameter spreads for each reader."""
    from blender_addon.datasets.dataset import source_id
    from blender_addon.renderers.lipstick import render_lipstick
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.visibility import (camera_jacobian, masked_block_means, noise_variance, parameter_floor,
                                     render_information, seed_differences)

    unit = sampler.sample_unit(index)
    source = source_id(seed, index)
    cycles_seeds = [index + 1000 * k for k in range(seeds)]  # the first: the reference's

    def render(u, cycles_seed):
        return render_lipstick(spec.values(spec.denormalise(u)), source, res, samples, cycles_seed)

    def render_tone(offset, cycles_seed):
        with lip_tone_shift(float(offset[0])):
            return render(unit, cycles_seed)

    block = max(res // 16, 1)  # the same patch of lips at every resolution
    mask = lips_mask(source, res)
    noisy = np.stack([render(unit, s) for s in cycles_seeds]).astype(np.float64)
    variance = noise_variance(masked_block_means(noisy, mask, block))
    differences = masked_block_means(seed_differences(render, unit, cycles_seeds), mask, block)
    tone = masked_block_means(seed_differences(render_tone, np.zeros(1), cycles_seeds, TONE_STEP), mask, block)
    camera = masked_block_means(camera_jacobian(noisy.mean(0)), mask, block)
    camera = np.broadcast_to(camera, (seeds, *camera.shape))
    # One information matrix for the parameters and every nuisance, so that each reader's floor is a marginal of the
    # same Gaussian: a reader told less can only do worse.
    information = render_information(np.concatenate([differences, camera, tone], axis=1), variance)
    size = len(prior)
    full_prior = np.zeros((size + 3, size + 3))
    full_prior[:size, :size] = prior
    full_prior[size: size + 2, size: size + 2] = camera_prior()
    full_prior[-1, -1] = TONE_PRIOR
    spreads = {"unit": unit, "prior": np.sqrt(np.diag(prior)), "reference": noisy[0].astype(np.float32)}
    for reader, unknown in (("known", size), ("camera", size + 2), ("tone", size + 3)):
        floor = parameter_floor(information[:unknown, :unknown], full_prior[:unknown, :unknown])
        spreads[reader] = np.sqrt(np.diag(floor)[:size])
    return spreads


def encoder_errors(spec, model: str, looks: list[dict], opaque: np.ndarray) -> tuple[float, list[float]]:
    """The model on the looks' references: median colour error on opaque looks (8-bit), mean |error| of OTHERS."""
    from vto_core.inference import EncoderSession

    found = EncoderSession(model).predict([look["reference"] for look in looks])
    found_unit = np.array([spec.normalise(spec.vector(f)) for f in found])
    truth = np.array([look["unit"] for look in looks])
    true_colour = np.array([lip_colour(spec.values(spec.denormalise(u))) for u in truth])
    colour_error = np.abs(np.array([lip_colour(f) for f in found]) - true_colour)[opaque]
    return float(np.median(colour_error)), [float(np.abs(found_unit[:, spec.modelled.index(n)] -
                                                          truth[:, spec.modelled.index(n)]).mean()) for n in OTHERS]


def run(n: int, seed: int, settings: list[tuple[int, int]], seeds: int, model: str) -> str:
    """The section, as markdown."""
    from vto_core.presets import load_presets, preset_matrix
    from vto_core.sampling import ParamSampler
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    sampler = ParamSampler(spec, preset_matrix(spec, load_presets("lipstick")), 0.5, seed)
    colour = [spec.modelled.index(name) for name in COLOUR]
    others = [spec.modelled.index(name) for name in OTHERS]
    prior = np.cov(np.stack([sampler.sample_unit(10**6 + i) for i in range(PRIOR_DRAWS)]).T)
    opaque = np.array([spec.values(spec.denormalise(sampler.sample_unit(i)))["opacity"] >= 0.5 for i in range(n)])
    rows = []
    for res, samples in settings:
        start = time.perf_counter()
        looks = [measure_look(spec, sampler, prior, seed, i, res, samples, seeds) for i in range(n)]
        seconds = (time.perf_counter() - start) / n
        for reader, reader_text in READERS.items():
            stds = np.array([look[reader] for look in looks])
            row = [f"{res} px, {samples} spp", reader_text,
                   f"{pooled_median_error(stds[opaque][:, colour] * 255.0):.1f}",
                   *(f"{np.sqrt(2 / np.pi) * stds[:, j].mean():.3f}" for j in others)]
            rows.append(row)
        if res == 64 and samples == 16:
            colour_error, other_errors = encoder_errors(spec, model, looks, opaque)
            rows.append([f"{res} px, {samples} spp", "the shipped encoder (reads the reference)", f"{colour_error:.1f}",
                         *(f"{e:.3f}" for e in other_errors)])
        print(f"{res} px {samples} spp: {seconds:.1f} s a look", flush=True)
    setting_text = ",".join(f"{r}x{s}" for r, s in settings)
    return (f"## What one render can tell: the floor for any encoder\n\n{n} fresh looks (seed {seed}; {int(opaque.sum())} "
            f"with opacity >= 0.5) of the default scene under portrait light. On each of {seeds} Cycles seeds: the render "
            "and its central differences of 0.05 in each encoded unit, as means of the lips' blocks (a sixteenth of "
            "the frame a side); the information is one half of the seeds' differences against the other's, so that "
            "the noise a changed parameter brings (Cycles samples other paths) does not count as signal. The error "
            "an ideal reader of one render would make (Gaussian posterior about each look, the sampler's spread as "
            "prior): colour as the median over opaque looks and R, G, B in 8-bit steps, the others as mean absolute "
            "errors in the encoded unit range (as `vto eval`'s).\n\n"
            + table(["render", "reader", "colour error /255, opacity >= 0.5", "opacity", "gloss", "reflection"], rows)
            + f"\n\nReproduce: `python -m benchmarks.bench_render_floor --n {n} --seed {seed} --settings {setting_text} "
            f"--seeds {seeds}`.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=48)
    parser.add_argument("--seed", type=int, default=8101)
    parser.add_argument("--settings", default="64x16,64x64,128x16", help="RESxSAMPLES,... to measure")
    parser.add_argument("--seeds", type=int, default=4, help="Cycles seeds a look (even, >= 2)")
    parser.add_argument("--model", default="blender_addon/models/lipstick_encoder.onnx")
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    settings = [tuple(int(v) for v in item.split("x")) for item in args.settings.split(",")]
    write_section("colour_floor", "render-floor", run(args.n, args.seed, settings, max(args.seeds, 2), args.model),
                  Path(args.results))


if __name__ == "__main__":
    main()
