"""`vto eval`: the paper's transfer experiment (7.2.1) on an exported encoder, with preset baselines.

For each of N sampled looks g: render it on source A (the reference) and on source B (the truth); estimate g from
the A render; render the estimate on B with the Cycles seed of the truth; compare. Baselines are the mean preset
and the nearest preset (the preset whose render on A is closest to the reference: what an artist does by hand).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vto_core.cli import ArgumentParser
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.inference import EncoderSession
from vto_core.metrics import mse, psnr, ssim
from vto_core.presets import load_presets, preset_matrix
from vto_core.sampling import ParamSampler
from vto_core.specs import RendererSpec

from .commands import render

SOURCE_POOL = 8  # distinct A and B sources; presets are rendered once per A source
_A_OFFSET, _B_OFFSET = 5000, 6000  # default-scene seeds far from the dataset's (random 31-bit) ones


@dataclass
class EvalSettings:
    """What an evaluation run renders: N looks at res px, `samples` spp, drawn with `seed`."""

    n: int = 24
    res: int = 64
    samples: int = DEFAULT_SAMPLES
    seed: int = 777
    refine: tuple[int, ...] = ()  # render budgets of the encoder + render-search methods
    search_from_mean: tuple[int, ...] = ()  # render budgets of render search started at the mean preset


def parameter_errors(spec: RendererSpec, truth_unit: np.ndarray, estimate_unit: np.ndarray) -> np.ndarray:
    """|estimate - truth| in unit space, hue on the circle: (m,) each in [0, 1] (0.5 at most for wrapping ones)."""
    error = np.abs(np.asarray(estimate_unit, np.float64) - np.asarray(truth_unit, np.float64))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    return np.where(wraps, np.minimum(error, 1.0 - error), error)


def dark(renderer: str, values: dict[str, float]) -> bool:
    """A very dark product: lipstick max(R, G, B) < 60; hair whose recoloured swatch has mean luminance < 0.15."""
    if renderer == "lipstick":
        return max(values["red"], values["green"], values["blue"]) < 60
    from vto_core.colour import luminance
    from vto_core.hair import swatch_target

    from .hair import load_swatch

    return float(luminance(swatch_target(load_swatch(), values)).mean()) < 0.15


def buckets(spec: RendererSpec, values: dict[str, float], unit: np.ndarray) -> list[str]:
    """The groups a look belongs to: dark, high gloss (> 2, the 75th percentile), range extremes (unit < 0.1, > 0.9)."""
    found = ["dark"] if dark(spec.renderer, values) else []
    if "gloss" in spec.modelled and values["gloss"] > 2.0:
        found.append("high gloss")
    if (np.asarray(unit) < 0.1).any() or (np.asarray(unit) > 0.9).any():
        found.append("range extreme")
    return found or ["other"]


def run_eval(model: str, out: str, settings: EvalSettings) -> dict:
    """Run the transfer experiment; writes results.json, results.md, psnr.png, errors.png and sheet.png to `out`."""
    session = EncoderSession(model)
    spec = session.spec
    renderer = spec.renderer
    if settings.n < 1:
        raise VtoError(f"--n must be at least 1, got {settings.n}")
    presets = load_presets(renderer)
    preset_units = preset_matrix(spec, presets)
    sampler = ParamSampler(spec, preset_units, 0.5, settings.seed)
    mean_values = spec.values(spec.denormalise(preset_units.mean(axis=0)))

    def draw(values: dict, source: int, seed: int) -> np.ndarray:
        return render(renderer, values, source, settings.res, settings.samples, seed)

    preset_cache: dict[int, dict[str, np.ndarray]] = {}
    rows, sheet = [], []
    out_dir = Path(out)
    from tqdm import tqdm

    for index in tqdm(range(settings.n), desc="eval", unit="look"):
        unit = sampler.sample_unit(index)
        values = spec.values(spec.denormalise(unit))
        source_a = _A_OFFSET + index % SOURCE_POOL
        source_b = _B_OFFSET + index % SOURCE_POOL
        seed = index
        reference, truth = draw(values, source_a, seed), draw(values, source_b, seed)
        estimates, timings = {}, {}

        start = time.perf_counter()
        estimates["encoder"] = session.predict(reference)[0]
        timings["encoder"] = time.perf_counter() - start
        estimates["mean preset"] = mean_values
        timings["mean preset"] = 0.0
        start = time.perf_counter()
        if source_a not in preset_cache:
            preset_cache[source_a] = {name: draw(spec.full_values(p), source_a, 0) for name, p in presets.items()}
        nearest = min(preset_cache[source_a], key=lambda name: mse(preset_cache[source_a][name], reference))
        estimates["nearest preset"] = spec.full_values(presets[nearest])
        timings["nearest preset"] = (time.perf_counter() - start) if index < SOURCE_POOL else float("nan")

        searches = [("encoder", budget) for budget in settings.refine]
        searches += [("mean preset", budget) for budget in settings.search_from_mean]
        for start_method, budget in searches:
            from .refine import refine_by_render

            def render_unit(u, source_a=source_a, seed=seed):
                return draw(spec.values(spec.denormalise(u)), source_a, seed)

            name = f"encoder + render search {budget}" if start_method == "encoder" else \
                f"render search {budget} from the mean preset"
            start = time.perf_counter()
            found = refine_by_render(render_unit, reference, spec.normalise(spec.vector(estimates[start_method])),
                                     budget, seed)
            estimates[name] = spec.values(spec.denormalise(found.unit))
            timings[name] = timings[start_method] + time.perf_counter() - start

        row = {"index": index, "source_a": source_a, "source_b": source_b, "truth": values, "buckets":
               buckets(spec, values, unit), "methods": {}}
        images = [reference, truth]
        for method, estimate in estimates.items():
            on_b = draw(estimate, source_b, seed)
            estimate_unit = spec.normalise(spec.vector(estimate))
            row["methods"][method] = {
                "psnr": psnr(on_b, truth), "ssim": ssim(on_b, truth), "ms": 1000 * timings[method],
                "param_error": dict(zip(spec.modelled, parameter_errors(spec, unit, estimate_unit).round(5).tolist())),
                "estimate": {k: round(float(v), 4) for k, v in estimate.items() if k in spec.modelled},
            }
            if method in ("encoder", "nearest preset"):
                images.append(on_b)
        rows.append(row)
        if len(sheet) < 8:
            sheet.append(np.concatenate(images, axis=1))

    summary = _summarise(spec, rows)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "results.json").write_text(json.dumps({"model": str(model), "settings": settings.__dict__,
                                                      "summary": summary, "looks": rows}, indent=1))
    (out_dir / "results.md").write_text(_markdown(spec, summary, settings, model))
    write_image(out_dir / "sheet.png", np.concatenate(sheet, axis=0))
    _plots(spec, rows, out_dir)
    return summary


def _summarise(spec: RendererSpec, rows: list[dict]) -> dict:
    """Per method: mean/median PSNR, SSIM, ms, per-parameter mean error, and PSNR per bucket."""
    summary = {}
    for method in rows[0]["methods"]:
        results = [row["methods"][method] for row in rows]
        per_bucket = {}
        for row, result in zip(rows, results):
            for bucket in row["buckets"]:
                per_bucket.setdefault(bucket, []).append(result["psnr"])
        summary[method] = {
            "psnr_mean": float(np.mean([r["psnr"] for r in results])),
            "psnr_median": float(np.median([r["psnr"] for r in results])),
            "ssim_mean": float(np.mean([r["ssim"] for r in results])),
            "ms_per_reference": float(np.nanmean([r["ms"] for r in results])),
            "param_error": {name: float(np.mean([r["param_error"][name] for r in results])) for name in spec.modelled},
            "psnr_by_bucket": {k: [float(np.mean(v)), len(v)] for k, v in sorted(per_bucket.items())},
        }
    return summary


def _markdown(spec: RendererSpec, summary: dict, settings: EvalSettings, model: str) -> str:
    methods = list(summary)
    lines = [f"# Transfer evaluation of {Path(model).name} ({spec.renderer})", "",
             f"{settings.n} sampled looks (seed {settings.seed}), {settings.res} px, {settings.samples} spp; reference on "
             f"source A, compared on source B with the truth's Cycles seed.", "",
             "| method | PSNR mean dB | PSNR median dB | SSIM | ms per reference |", "|---|---|---|---|---|"]
    lines += [f"| {m} | {summary[m]['psnr_mean']:.2f} | {summary[m]['psnr_median']:.2f} | {summary[m]['ssim_mean']:.4f} "
              f"| {summary[m]['ms_per_reference']:.1f} |" for m in methods]
    lines += ["", "Mean absolute parameter error (fraction of each range; hue on the circle):", "",
              "| parameter | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    lines += [f"| {name} | " + " | ".join(f"{summary[m]['param_error'][name]:.3f}" for m in methods) + " |"
              for name in spec.modelled]
    buckets_seen = sorted({b for m in methods for b in summary[m]["psnr_by_bucket"]})
    lines += ["", "PSNR by bucket (dB, looks):", "", "| bucket | " + " | ".join(methods) + " |",
              "|---|" + "---|" * len(methods)]
    for bucket in buckets_seen:
        cells = [summary[m]["psnr_by_bucket"].get(bucket) for m in methods]
        lines.append(f"| {bucket} | " + " | ".join(f"{c[0]:.2f} ({c[1]})" if c else "-" for c in cells) + " |")
    lines += ["", "The sheet (sheet.png) shows per row: reference on A | truth on B | encoder on B | nearest preset "
                  "on B."]
    return "\n".join(lines) + "\n"


def _plots(spec: RendererSpec, rows: list[dict], out_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(rows[0]["methods"])
    figure, axis = plt.subplots(figsize=(6, 3.5))
    axis.boxplot([[row["methods"][m]["psnr"] for row in rows] for m in methods], tick_labels=methods)
    axis.set_ylabel("transfer PSNR on source B (dB)")
    figure.tight_layout()
    figure.savefig(out_dir / "psnr.png", dpi=100)
    plt.close(figure)
    figure, axis = plt.subplots(figsize=(7, 3.5))
    width = 0.8 / len(methods)
    for k, method in enumerate(methods):
        errors = [np.mean([row["methods"][method]["param_error"][name] for row in rows]) for name in spec.modelled]
        axis.bar(np.arange(spec.size) + k * width, errors, width, label=method)
    axis.set_xticks(np.arange(spec.size) + 0.4 - width / 2, spec.modelled, rotation=30)
    axis.set_ylabel("mean |error| (fraction of range)")
    axis.legend()
    figure.tight_layout()
    figure.savefig(out_dir / "errors.png", dpi=100)
    plt.close(figure)


def cmd_eval(argv: list[str]) -> int:
    """vto eval --model M.onnx [--n N] [--res R] [--samples S] [--seed S] [--refine render:B,...] --out DIR."""
    parser = ArgumentParser(prog="vto eval", description="the paper's transfer experiment on an exported encoder")
    parser.add_argument("--model", required=True, help="an encoder exported with `vto export`")
    parser.add_argument("--out", required=True, help="folder for results.json, results.md, plots and sheet.png")
    parser.add_argument("--n", type=int, default=EvalSettings.n)
    parser.add_argument("--res", type=int, default=EvalSettings.res)
    parser.add_argument("--samples", type=int, default=EvalSettings.samples)
    parser.add_argument("--seed", type=int, default=EvalSettings.seed, help="seed of the sampled looks")
    parser.add_argument("--refine", default="", help="extra methods: render:B,... (encoder + CMA-ES, B renders)")
    args = parser.parse_args(argv)
    from .match import parse_refine

    budgets = tuple(parse_refine(item)[1] for item in args.refine.split(",") if item)
    summary = run_eval(args.model, args.out, EvalSettings(args.n, args.res, args.samples, args.seed, budgets))
    print(json.dumps({"out": args.out, **{m: {k: v for k, v in s.items() if k in ("psnr_mean", "ssim_mean")}
                                          for m, s in summary.items()}}))
    return 0
