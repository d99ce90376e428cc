"""Refinement through the real renderer on the reference's own source: the fit against CMA-ES, at equal renders.

Two `vto eval` runs of one encoder on the same references: the searches render on the reference's own Cycles seed
(its noise shared, as on a render of one's own scene) and on another seed (noise of their own, as against a photo of
the scene). Per method: the transfer gain over the mean preset, the median colour error on looks with opacity >= 0.5
(lipstick), each parameter's mean absolute error (unit range) and the milliseconds a reference. Writes the
'refine-RENDERER' section of benchmarks/results/refine.md.

    python -m benchmarks.bench_refine [--model M.onnx] [--n 48] [--seed 9001] [--refine render:25,cma:25,render:60]
        [--reuse SAME_SEED_DIR OTHER_SEED_DIR]   # format two finished `vto eval` folders instead of running them
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from benchmarks.common import RESULTS, table, write_section

OTHER_SEED = 1000  # the searches' Cycles seed past the reference's in the second run
NOISE = {0: "shared with the reference", OTHER_SEED: "its own"}


def evaluate(model: str, n: int, seed: int, refine: tuple[str, ...], offset: int, folder: Path) -> dict:
    """One `vto eval` into `folder` -> its results.json."""
    from pipeline.evaluate import EvalSettings, run_eval

    run_eval(model, str(folder), EvalSettings(n, seed=seed, refine=refine, search_seed_offset=offset, quiet=True))
    return json.loads((folder / "results.json").read_text())


def section(results: dict[int, dict], command: str) -> tuple[str, str]:
    """(renderer, markdown) of the runs by seed offset."""
    first = results[0]
    names = first["modelled"]
    colour = first["renderer"] == "lipstick"
    rows = []
    for offset, result in results.items():
        for method, summary in result["summary"].items():
            if method == "mean preset" or (offset and method == "encoder"):
                continue  # the same in both runs: shown once
            row = [method, "-" if method == "encoder" else NOISE[offset], f"{summary['gain_over_mean_preset_db']:+.2f}"]
            if colour:
                row.append(f"{summary['colour_error_median']['opaque']:.1f}")
            row += [f"{summary['param_error'][name]:.3f}" for name in names]
            row.append(f"{summary['ms_per_reference']:,.0f}")
            rows.append(row)
    settings = first["settings"]
    header = ["method", "search renders' noise", "gain over mean preset dB"]
    header += ["colour error /255, opacity >= 0.5"] if colour else []
    header += [*names, "ms a reference"]
    text = (f"## {first['renderer']}: the fit and CMA-ES through the renderer\n\n`vto eval` of "
            f"{Path(first['model']).name} on {settings['n']} fresh looks (eval seed {settings['seed']}), "
            f"{settings['res']} px, {settings['samples']} spp, twice: the searches render on the reference's own "
            f"source with its Cycles seed, then with that seed + {OTHER_SEED}. Parameter errors are mean absolute "
            "errors in the encoded unit range. \"Render search\" is the fit "
            "(blender_addon.matching.refine.iter_fit), the default of `--refine render:B`; \"CMA-ES search\" is "
            "`--refine cma:B`.\n\n"
            + table(header, rows) + f"\n\nReproduce: `{command}`.")
    return first["renderer"], text


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="blender_addon/models/lipstick_encoder.onnx")
    parser.add_argument("--n", type=int, default=48)
    parser.add_argument("--seed", type=int, default=9001)
    parser.add_argument("--refine", default="render:25,cma:25,render:60")
    parser.add_argument("--reuse", nargs=2, metavar=("SAME_SEED_DIR", "OTHER_SEED_DIR"), default=None)
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    command = (f"python -m benchmarks.bench_refine --model {args.model} --n {args.n} --seed {args.seed} "
               f"--refine {args.refine}")
    if args.reuse:
        results = {offset: json.loads((Path(folder) / "results.json").read_text())
                   for offset, folder in zip(NOISE, args.reuse)}
    else:
        with tempfile.TemporaryDirectory() as folder:
            results = {offset: evaluate(args.model, args.n, args.seed, tuple(args.refine.split(",")), offset,
                                        Path(folder) / str(offset)) for offset in NOISE}
    renderer, text = section(results, command)
    write_section("refine", f"refine-{renderer}", text, Path(args.results))


if __name__ == "__main__":
    main()
