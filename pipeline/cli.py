"""The pipeline layer's commands: `vto eval` (the transfer experiment); `vto demo` and `vto match` are in their modules."""

from __future__ import annotations

import json

from vto_core.cli import ArgumentParser, products_that
from vto_core.errors import VtoError


def cmd_eval(argv: list[str]) -> int:
    """vto eval --model M.onnx [--imitator RUN] [--n N] [--res R] [--samples S] [--seed S] [--refine LIST] --out DIR."""
    from .evaluate import EvalSettings, run_eval

    parser = ArgumentParser(prog="vto eval", description="the paper's transfer experiment (7.2.1) on an exported "
                                                         "encoder, against the mean and nearest presets")
    parser.add_argument("--model", required=True, help="an encoder exported with `vto export`")
    parser.add_argument("--out", required=True, help="folder for results.json, results.md, plots and sheet.png")
    parser.add_argument("--imitator", default=None, help="imitator run, for imitator:K refinement")
    parser.add_argument("--n", type=int, default=EvalSettings.n, help="sampled looks")
    parser.add_argument("--res", type=int, default=EvalSettings.res)
    parser.add_argument("--samples", type=int, default=EvalSettings.samples)
    parser.add_argument("--seed", type=int, default=EvalSettings.seed, help="seed of the sampled looks")
    parser.add_argument("--refine", default="", help="refinements of the encoder's estimate, e.g. "
                                                     "imitator:10,render:25")
    parser.add_argument("--search-from-mean", default="", help="render budgets of render search from the mean preset, "
                                                               "e.g. 400")
    parser.add_argument("--compare", action="append", default=[], metavar="NAME=MODEL",
                        help="another encoder of the same spec, evaluated on the same references (repeatable)")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"],
                        help=f"{products_that('lightings')}: the default scene's lighting (default portrait)")
    parser.add_argument("--search-seed-offset", type=int, default=0,
                        help="Cycles seed of what methods render on source A, past the reference's (0: its own seed, "
                             "the reference's noise shared; another value: noise of their own, as against a photo)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    compare = tuple(tuple(item.split("=", 1)) for item in args.compare)
    if any(len(pair) != 2 or not all(pair) for pair in compare):
        raise VtoError(f"--compare takes NAME=MODEL.onnx, got {args.compare}")
    try:
        from_mean = tuple(int(b) for b in args.search_from_mean.split(",") if b.strip())
    except ValueError:
        raise VtoError(f"--search-from-mean takes render budgets like 100,400, got '{args.search_from_mean}'") from None
    settings = EvalSettings(args.n, args.res, args.samples, args.seed, tuple(r for r in args.refine.split(",") if r),
                            from_mean, args.imitator, compare, lighting=args.lighting,
                            search_seed_offset=args.search_seed_offset, quiet=args.quiet)
    summary = run_eval(args.model, args.out, settings)
    print(json.dumps({"out": args.out, **{m: {"psnr": s["psnr"][0], "ssim": s["ssim"][0], "ms": s["ms_per_reference"]}
                                          for m, s in summary.items()}}))
    return 0
