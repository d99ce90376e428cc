"""How precisely one render of a product's default scene can tell its parameters: a floor for any encoder.

For N fresh looks (drawn as `vto eval` draws them), on each of K Cycles seeds: the render and its central differences
in each modelled parameter, as means of the region's blocks (the lips, the lid). One half of the seeds' differences
against the other's gives the render's information (vto_core.visibility.render_information: a changed parameter also
changes the noise, which must not count as signal), and with the sampler's spread as prior the posterior spread of
each parameter (vto_core.visibility.parameter_floor). Four readers, each told less than the one before: one that
knows the scene (source, light, camera); one that must also allow for the camera's residual exposure and
white-balance error without metering the skin; one that does not know the bare region's own tone either (its one
freedom across sources besides the skin's, where the product's scene has one: ProductRenderer.bare_tone); and one
that does not know the light's direction (its turn about three axes) or its fill either, each with the spread a
source draws it with (lighting.turned_light; the map itself, the skin tone and the shape stay known). From those
spreads: the median colour error (8-bit steps, R, G and B pooled) on the looks with opacity >= 0.5 and the mean
absolute error of every other modelled parameter (unit range) that such an ideal reader would make, at each
resolution and sample count asked for. Noise is taken as independent between blocks, the light is linearised about
its draw, and the rest of the source is known (vto eval hides it), so the floor is optimistic. On the 64 px,
default-sample renders the shipped encoder reads the same references (the last row). Writes the section
'render-floor-<product>' of benchmarks/results/colour_floor.md.

    python -m benchmarks.bench_render_floor [--renderer lipstick] [--n 48] [--seed 8101]
        [--settings 64x16,64x64,128x16] [--seeds 4] [--looks FILE.npz]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, table, write_section

COLOUR = ("red", "green", "blue")
OPAQUE = 0.5  # colour errors are read on looks at least this opaque, as vto eval reads them
PRIOR_DRAWS = 20000
READERS = {"prior": "no render (the sampler's spread)", "known": "knows the scene",
           "camera": "+ the camera's residual exposure and white balance unknown",
           "tone": "+ the bare region's tone unknown",
           "light": "+ the light's direction and fill unknown"}
LIGHT_STEP = 0.05  # radians of turn, and of log fill, of the light's central differences


def light_prior() -> np.ndarray:
    """(4, 4) covariance of a source's light about its draw (vto_core.portrait_light): its turn about the camera's x
    and y axes (the key anywhere in a cap of KEY_CONE radians) and about z (any roll), and its log fill."""
    from vto_core.portrait_light import FILL_RANGE, KEY_CONE

    log_fill = np.log(np.random.default_rng(0).uniform(*FILL_RANGE, 100000))
    return np.diag([KEY_CONE**2 / 4, KEY_CONE**2 / 4, (2 * np.pi) ** 2 / 12, log_fill.var()])


def pooled_median_error(stds: np.ndarray, draws: int = 400, seed: int = 0) -> float:
    """stds (N, C) of Gaussian errors -> the median |error| over every look, channel and draw."""
    if stds.size == 0:
        return float("nan")
    rng = np.random.default_rng(seed)
    return float(np.median(np.abs(rng.normal(size=(draws, *stds.shape)) * stds)))


def colour_text(error: float) -> str:
    """A colour error's cell: '-' where there was none to take (no opaque look)."""
    return "-" if np.isnan(error) else f"{error:.1f}"


def camera_prior() -> np.ndarray:
    """(2, 2) covariance of the default camera's residual errors: uniform exposure (stops) and white-balance shift."""
    from vto_core.portrait_light import EXPOSURE_EV, WARM_COOL

    return np.diag([(2 * EXPOSURE_EV) ** 2 / 12, (2 * WARM_COOL) ** 2 / 12])


def measure_look(renderer, sampler, prior: np.ndarray, seed: int, index: int, res: int, samples: int,
                 seeds: int) -> dict:
    """Renders of one look: derivatives and noise on `seeds` Cycles seeds -> per-parameter spreads for each reader."""
    from blender_addon.datasets.dataset import source_id
    from blender_addon.renderers.lighting import turned_light
    from vto_core.portrait_light import axis_angle
    from vto_core.visibility import (camera_jacobian, masked_block_means, noise_variance, parameter_floor,
                                     render_information, seed_differences)

    spec = sampler.spec
    unit = sampler.sample_unit(index)
    source = source_id(seed, index)
    cycles_seeds = [index + 1000 * k for k in range(seeds)]  # the first: the reference's
    bound = {s: renderer.bind(source, res, samples, s) for s in cycles_seeds}

    def render(u, cycles_seed):
        return bound[cycles_seed].render(spec.values(spec.denormalise(u)))

    def render_tone(offset, cycles_seed):
        with renderer.bare_tone(float(offset[0])):
            return render(unit, cycles_seed)

    def render_light(offset, cycles_seed):  # offsets about 0.5, so that seed_differences takes central differences
        x, y, z, fill = np.asarray(offset, np.float64) - 0.5
        turn = axis_angle(np.array([0.0, 0.0, 1.0]), z) @ axis_angle(np.array([0.0, 1.0, 0.0]), y) @ axis_angle(
            np.array([1.0, 0.0, 0.0]), x)
        with turned_light(renderer.default_scene(), turn, float(np.exp(fill))):
            return render(unit, cycles_seed)

    block = max(res // 16, 1)  # the same patch of the region at every resolution
    mask = bound[cycles_seeds[0]].mask
    noisy = np.stack([render(unit, s) for s in cycles_seeds]).astype(np.float64)
    variance = noise_variance(masked_block_means(noisy, mask, block))
    camera = masked_block_means(camera_jacobian(noisy.mean(0)), mask, block)
    columns = [masked_block_means(seed_differences(render, unit, cycles_seeds), mask, block),
               np.broadcast_to(camera, (seeds, *camera.shape))]
    priors, readers = [prior, camera_prior()], ["known", "camera"]  # each reader also does not know its nuisance
    if renderer.bare_tone_prior > 0:
        columns.append(masked_block_means(seed_differences(render_tone, np.zeros(1), cycles_seeds,
                                                           renderer.bare_tone_step), mask, block))
        priors.append(np.array([[renderer.bare_tone_prior]]))
        readers.append("tone")
    columns.append(masked_block_means(seed_differences(render_light, np.full(4, 0.5), cycles_seeds, LIGHT_STEP),
                                      mask, block))
    priors.append(light_prior())
    readers.append("light")
    # One information matrix for the parameters and every nuisance, so that each reader's floor is a marginal of the
    # same Gaussian: a reader told less can only do worse.
    information = render_information(np.concatenate(columns, axis=1), variance)
    sizes = np.cumsum([len(p) for p in priors])
    full_prior = np.zeros((sizes[-1], sizes[-1]))
    for p, end in zip(priors, sizes):
        full_prior[end - len(p): end, end - len(p): end] = p
    spreads = {"unit": unit, "prior": np.sqrt(np.diag(prior)), "reference": noisy[0].astype(np.float32)}
    for reader, unknown in zip(readers, sizes):
        floor = parameter_floor(information[:unknown, :unknown], full_prior[:unknown, :unknown])
        spreads[reader] = np.sqrt(np.diag(floor)[: sizes[0]])
    return spreads


def encoder_errors(spec, model: str, looks: list[dict], opaque: np.ndarray, others: list[str]
                   ) -> tuple[float, list[float]]:
    """The model on the looks' references: median colour error on opaque looks (8-bit), mean |error| of `others`."""
    from vto_core.inference import EncoderSession

    found = EncoderSession(model).predict([look["reference"] for look in looks])
    found_unit = np.array([spec.normalise(spec.vector(f)) for f in found])
    truth = np.array([look["unit"] for look in looks])
    true_colour = np.array([[spec.values(spec.denormalise(u))[c] for c in COLOUR] for u in truth])
    colour_error = np.abs(np.array([[f[c] for c in COLOUR] for f in found]) - true_colour)[opaque]
    columns = [spec.modelled.index(name) for name in others]
    return (float(np.median(colour_error)) if colour_error.size else float("nan"),
            [float(np.abs(found_unit[:, j] - truth[:, j]).mean()) for j in columns])


def run(product, n: int, seed: int, settings: list[tuple[int, int]], seeds: int, model: str,
        looks_file: str | None) -> str:
    """The section, as markdown."""
    from blender_addon.renderers.products import blender_side
    from vto_core.presets import load_presets, preset_matrix
    from vto_core.sampling import ParamSampler

    renderer = blender_side(product)
    spec = product.spec
    sampler = ParamSampler(spec, preset_matrix(spec, load_presets(product.name)), 0.5, seed)
    colour = [spec.modelled.index(name) for name in COLOUR]
    others = [name for name in spec.modelled if name not in COLOUR]
    prior = np.cov(np.stack([sampler.sample_unit(10**6 + i) for i in range(PRIOR_DRAWS)]).T)
    opaque = np.array([spec.values(spec.denormalise(sampler.sample_unit(i)))["opacity"] >= OPAQUE for i in range(n)])
    rows, kept = [], {}
    for res, samples in settings:
        start = time.perf_counter()
        looks = [measure_look(renderer, sampler, prior, seed, i, res, samples, seeds) for i in range(n)]
        seconds = (time.perf_counter() - start) / n
        for reader, reader_text in ((k, v) for k, v in READERS.items() if k in looks[0]):
            stds = np.array([look[reader] for look in looks])
            kept[f"{res}x{samples}_{reader}"] = stds
            rows.append([f"{res} px, {samples} spp", reader_text,
                         colour_text(pooled_median_error(stds[opaque][:, colour] * 255.0)),
                         *(f"{np.sqrt(2 / np.pi) * stds[:, spec.modelled.index(o)].mean():.3f}" for o in others)])
        if res == 64 and samples == 16:
            colour_error, other_errors = encoder_errors(spec, model, looks, opaque, others)
            rows.append([f"{res} px, {samples} spp", "the shipped encoder (reads the reference)",
                         colour_text(colour_error), *(f"{e:.3f}" for e in other_errors)])
        print(f"{res} px {samples} spp: {seconds:.1f} s a look", flush=True)
    if looks_file:  # each reader's spreads (N, P) a setting, the looks' units (N, P) and the opaque ones
        np.savez(looks_file, units=np.array([sampler.sample_unit(i) for i in range(n)]), opaque=opaque,
                 modelled=np.array(spec.modelled), **kept)
    setting_text = ",".join(f"{r}x{s}" for r, s in settings)
    return (f"## What one render can tell of {product.label.lower()}: the floor for any encoder\n\n{n} fresh looks "
            f"(seed {seed}; {int(opaque.sum())} with opacity >= {OPAQUE}) of the default scene, as `vto eval` draws "
            f"them. On each of {seeds} Cycles seeds: the render and its central differences of 0.05 in each encoded "
            f"unit, as means of the {product.region}' blocks (a sixteenth of the frame a side); the information is "
            "one half of the seeds' differences against the other's, so that the noise a changed parameter brings "
            "(Cycles samples other paths) does not count as signal. The error an ideal reader of one render would "
            "make (Gaussian posterior about each look, the sampler's spread as prior): colour as the median over "
            "opaque looks and R, G, B in 8-bit steps (- where no look is opaque), the others as mean absolute errors "
            "in the encoded unit range (as `vto eval`'s)."
            "\n\n" + table(["render", "reader", f"colour error /255, opacity >= {OPAQUE}", *others], rows)
            + f"\n\nReproduce: `python -m benchmarks.bench_render_floor --renderer {product.name} --n {n} --seed "
            f"{seed} --settings {setting_text} --seeds {seeds}`.")


def main() -> None:
    from vto_core.products import get_product, product_names

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--renderer", default="lipstick",
                        choices=[name for name in product_names() if get_product(name).is_material])
    parser.add_argument("--n", type=int, default=48)
    parser.add_argument("--seed", type=int, default=8101)
    parser.add_argument("--settings", default="64x16,64x64,128x16", help="RESxSAMPLES,... to measure")
    parser.add_argument("--seeds", type=int, default=4, help="Cycles seeds a look (even, >= 2)")
    parser.add_argument("--model", default=None, help="the encoder read on the references (default: the shipped one)")
    parser.add_argument("--looks", default=None, help="also write each look's spreads to this .npz")
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    product = get_product(args.renderer)
    model = args.model or str(Path(__file__).parents[1] / "blender_addon" / "models" / f"{product.name}_encoder.onnx")
    settings = [tuple(int(v) for v in item.split("x")) for item in args.settings.split(",")]
    write_section("colour_floor", f"render-floor-{product.name}",
                  run(product, args.n, args.seed, settings, max(args.seeds, 2), model, args.looks), Path(args.results))


if __name__ == "__main__":
    main()
