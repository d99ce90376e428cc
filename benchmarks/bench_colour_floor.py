"""What the lipstick encoder's colour error is made of: one brightness scale per look, and the rest.

Renders N fresh looks of the default lips scene (portrait lighting, 64 px) three times from one seed, so that only
the camera's residual error differs: as shipped (exposure within +-1/3 stop, white balance within +-3 %), without
the exposure residual, and without either: the counterfactual of a camera that meters exactly, which the benchmark
sets through portrait_light's own arguments. For each model, on the looks with opacity >= 0.5: the median colour
error in 8-bit steps; what is left of it once one brightness scale per look is taken out (the estimate against the
truth scaled in linear light by the factor that fits it best: a lighter or darker paint of the right hue); and that
factor's median size in stops. Writes a section of benchmarks/results/colour_floor.md.

    python -m benchmarks.bench_colour_floor --work DIR [--model NAME=MODEL.onnx ...] [--n 300] [--seed 61]
"""

from __future__ import annotations

import argparse
import contextlib
import functools
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, lip_colour, table, write_section

CAMERAS = (  # (name, the camera's residual exposure error in stops, its white-balance error)
    ("as shipped: +-1/3 stop, +-3 % white balance", None, None),
    ("no exposure residual", 0.0, None),
    ("neither residual", 0.0, 0.0),
)


def brightness_split(truth: np.ndarray, estimate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """truth, estimate (N, 3) 8-bit sRGB -> (scale (N,) in stops, rest (N, 3) 8-bit): the estimate's linear-light
    brightness against the truth's (least squares), and |estimate - truth at that brightness|."""
    from vto_core.colour import linear_to_srgb, srgb_to_linear

    true_linear, found_linear = srgb_to_linear(truth / 255.0), srgb_to_linear(estimate / 255.0)
    factor = (true_linear * found_linear).sum(1) / np.maximum((true_linear**2).sum(1), 1e-9)
    rescaled = linear_to_srgb(np.clip(factor[:, None] * true_linear, 0.0, 1.0)) * 255.0
    return np.log2(np.maximum(factor, 1e-6)), np.abs(estimate - rescaled)


@contextlib.contextmanager
def camera(exposure_ev: float | None, warm_cool: float | None):
    """Renders of the default scene in this block use these residual camera errors (None: as shipped)."""
    from blender_addon.renderers import lighting

    settings = {k: v for k, v in (("exposure_ev", exposure_ev), ("warm_cool", warm_cool)) if v is not None}
    shipped = lighting.portrait_light
    lighting.portrait_light = functools.partial(shipped, **settings)
    try:
        yield
    finally:
        lighting.portrait_light = shipped


def render_looks(folder: Path, n: int, seed: int, exposure_ev: float | None, warm_cool: float | None):
    """`vto dataset lipstick` of n looks into `folder` (resumed if there) under that camera -> its DatasetReader."""
    from blender_addon.datasets.commands import cmd_dataset
    from vto_core.dataset import DatasetReader

    with camera(exposure_ev, warm_cool):
        cmd_dataset(["lipstick", "--out", str(folder), "--n", str(n), "--seed", str(seed), "--lighting", "portrait",
                     "--no-source", "--quiet"])
    return DatasetReader(folder)


def errors(reader, model: str) -> list[str]:
    """One table row for `model` on the looks of `reader`: colour error, its rest, the scale, other parameters."""
    from vto_core.inference import EncoderSession

    samples = [reader[i] for i in range(len(reader))]
    truth = [reader.spec.values(s.raw) for s in samples]
    found = EncoderSession(model).predict([s.render for s in samples])
    opaque = np.array([t["opacity"] >= 0.5 for t in truth])
    true_colour = np.array([lip_colour(t) for t in truth])[opaque]
    found_colour = np.array([lip_colour(f) for f in found])[opaque]
    scale, rest = brightness_split(true_colour, found_colour)
    spec = reader.spec
    unit_error = np.abs(np.array([spec.normalise(spec.vector(f)) for f in found]) - np.stack([s.unit for s in samples]))
    others = [unit_error[:, spec.modelled.index(name)].mean() for name in ("opacity", "gloss", "reflection")]
    return [f"{np.median(np.abs(found_colour - true_colour)):.1f}", f"{np.median(rest):.1f}",
            f"{np.median(np.abs(scale)):.2f}", str(int(opaque.sum())), *(f"{e:.3f}" for e in others)]


def run(work: Path, models: list[tuple[str, str]], n: int, seed: int) -> str:
    """The table, as markdown."""
    rows = []
    for index, (name, exposure_ev, warm_cool) in enumerate(CAMERAS):
        reader = render_looks(work / f"camera{index}", n, seed, exposure_ev, warm_cool)
        rows += [[name, model_name, *errors(reader, model)] for model_name, model in models]
    return (f"## The colour error, split\n\n{n} fresh looks (seed {seed}) rendered three times, the camera's residual "
            "error the only change; medians over the looks with opacity >= 0.5 and their channels, in 8-bit steps. "
            "\"Rest\" is what is left once one brightness scale per look is taken out; the scale's median size is "
            "in stops. The last three columns are mean absolute errors in the encoder's unit range (as `vto eval`'s).\n\n"
            + table(["camera", "model", "colour error", "rest", "brightness scale (stops)", "opaque looks",
                     "opacity", "gloss", "reflection"], rows)
            + "\n\nReproduce: `python -m benchmarks.bench_colour_floor --work DIR "
            + " ".join(f"--model '{name}={model}'" for name, model in models) + f" --n {n} --seed {seed}`.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", required=True, help="folder for the three renders (resumed if there)")
    parser.add_argument("--model", action="append", default=[], metavar="NAME=MODEL.onnx")
    parser.add_argument("--n", type=int, default=300)
    parser.add_argument("--seed", type=int, default=61)
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    models = [tuple(m.split("=", 1)) for m in args.model] or [("shipped",
                                                                 "blender_addon/models/lipstick_encoder.onnx")]
    write_section("colour_floor", "colour-floor", run(Path(args.work), models, args.n, args.seed), Path(args.results))


if __name__ == "__main__":
    main()
