"""`vto eval`: the paper's transfer experiment (7.2.1) on an exported encoder, with preset baselines and refinement.

For each of N sampled looks g: render it on source A (the reference) and on source B (the truth); estimate g from
the A render; render the estimate on B with the Cycles seed of the truth (so render noise does not count); compare
with PSNR, SSIM and, where VGG16 weights exist, the perceptual distance, plus per-parameter absolute error.
Baselines: the mean preset, and the nearest preset (every preset rendered on A, the closest to the reference kept:
what an artist does by hand). Methods: the encoder, and each refinement of its estimate asked for (imitator:K,
render:B the fit through the renderer, cma:B the CMA-ES search), plus CMA-ES render search from the mean preset.

Layering: this is the pipeline layer, above blender_addon (the renderer, bpy) and training (the imitator's
refinement and the perceptual distance, torch); both are imported inside the functions that use them.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.inference import EncoderSession
from vto_core.metrics import mse, psnr, ssim
from vto_core.presets import load_presets, preset_matrix
from vto_core.sampling import ParamSampler
from vto_core.products import get_product
from vto_core.specs import RendererSpec

# Looks come from ParamSampler(seed=SEED_BASE + --seed): datasets use small seeds, so eval draws never repeat them.
SEED_BASE = 2**32
# Sources of look i: A = SOURCE_BASE + 2i, B = SOURCE_BASE + 2i + 1 (datasets draw random 31-bit source seeds).
SOURCE_BASE = 5000
EXTREME = 0.1  # a unit value below 0.1 or above 0.9 is at its range's extreme
COLOUR = ("red", "green", "blue")  # lipstick: the makeup colour's parameters
OPAQUE = 0.5  # lipstick: looks whose true opacity is at least this show their colour (issue 17's colour goal)


@dataclass
class EvalSettings:
    """What an evaluation run renders and which methods it compares."""

    n: int = 24
    res: int = 64
    samples: int = DEFAULT_SAMPLES
    seed: int = 777
    refine: tuple[str, ...] = ()  # refinements of the encoder's estimate: "imitator:K", "render:B"
    search_from_mean: tuple[int, ...] = ()  # render budgets of render search started at the mean preset
    imitator: str | None = None  # imitator run for imitator:K
    compare: tuple[tuple[str, str], ...] = ()  # (name, ONNX path): other encoders of the same spec, same references
    lighting: str | None = None  # the default lips scene's: "wide" or "portrait" (None: its default)
    # What methods render on A (nearest preset, searches) uses the reference's Cycles seed plus this: 0 shares the
    # reference's noise, as a search on a render of one's own scene can; another value is a photo's case.
    search_seed_offset: int = 0
    sheet_rows: int = 6
    quiet: bool = False


def parameter_errors(spec: RendererSpec, truth_unit: np.ndarray, estimate_unit: np.ndarray) -> np.ndarray:
    """|estimate - truth| in unit space, hue on the circle: (m,) each in [0, 1] (0.5 at most for wrapping ones)."""
    error = np.abs(np.asarray(estimate_unit, np.float64) - np.asarray(truth_unit, np.float64))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    return np.where(wraps, np.minimum(error, 1.0 - error), error)


def raw_errors(spec: RendererSpec, truth: dict[str, float], estimate: dict[str, float]) -> np.ndarray:
    """|estimate - truth| in each parameter's own units (R, G, B in 0-255 steps; hue in turns, on the circle): (m,)."""
    error = np.abs(spec.vector(estimate) - spec.vector(truth))
    span = np.array([p.high - p.low if p.wraps else np.inf for p in spec.modelled_params])
    return np.where(np.isfinite(span), np.minimum(error, span - error), error)


def is_dark(renderer: str, values: dict[str, float]) -> bool:
    """A very dark product (ProductRenderer.is_dark): lipstick max(R, G, B) < 60 of 255; hair: recoloured swatch
    mean luma < 0.05."""
    from blender_addon.renderers.products import blender_side

    return blender_side(renderer).is_dark(values)


def buckets(spec: RendererSpec, values: dict[str, float], unit: np.ndarray) -> list[str]:
    """The groups a look belongs to: 'dark', the product's own (Product.buckets: 'high gloss'), '<param> low' /
    '<param> high' (unit < 0.1 / > 0.9).

    Wrapping parameters (hue) have no extremes. A look in none of them is 'other'.
    """
    found = ["dark"] if is_dark(spec.renderer, values) else []
    found += [label for label, (name, above) in get_product(spec.renderer).buckets.items()
              if name in spec.modelled and values[name] > above]
    for param, u in zip(spec.modelled_params, np.asarray(unit, np.float64)):
        if not param.wraps and u < EXTREME:
            found.append(f"{param.name} low")
        elif not param.wraps and u > 1.0 - EXTREME:
            found.append(f"{param.name} high")
    return found or ["other"]


class PerceptualMeter:
    """The VGG16 perceptual distance of training.losses between two images, where weights exist (else None)."""

    def __init__(self):
        from training.losses import vgg16_weight_candidates

        self.looked_at = vgg16_weight_candidates()
        self.distance = None
        if any(path.is_file() for path in self.looked_at):
            from training.losses import PerceptualDistance

            self.distance = PerceptualDistance("vgg")

    def __call__(self, a: np.ndarray, b: np.ndarray) -> float | None:
        """(H, W, 3) x2 -> VGG feature distance, or None without weights."""
        if self.distance is None:
            return None
        import torch

        with torch.no_grad():
            x, y = (torch.from_numpy(np.ascontiguousarray(i.transpose(2, 0, 1), np.float32))[None] for i in (a, b))
            return float(self.distance(x, y))


def methods(settings: EvalSettings) -> dict[str, tuple[str, int]]:
    """The compared methods in table order: name -> (kind, K or B); kinds are 'mean', 'nearest', 'encoder',
    'imitator', 'render' (the fit) and 'cma' (refining the encoder's estimate), 'photo' (what a photo gets: Fast, the
    reference's region statistics fitted through the colour imitator, and Better or Best, then through the renderer on
    the default sources of blender_addon.matching.photo_fit, never A or B),
    'render from mean' (CMA-ES)."""
    from blender_addon.matching.match import parse_refine
    from vto_core.products import QUALITIES

    found = {"mean preset": ("mean", 0), "nearest preset": ("nearest", 0), "encoder": ("encoder", 0)}
    for item in settings.refine:
        if item.startswith("photo:"):  # Better / Best of a photo: the source hidden from the refinement
            quality = item.partition(":")[2].upper()
            if quality not in QUALITIES:
                raise VtoError(f"--refine photo:Q takes fast, better or best, got '{item}'")
            found[f"encoder + photo fit ({quality.lower()})"] = ("photo", quality)
            continue
        kind, amount = parse_refine(item)
        if kind == "imitator":
            found[f"encoder + imitator {amount}"] = (kind, amount)
        elif kind == "render":
            found[f"encoder + render search {amount}"] = (kind, amount)
        elif kind == "cma":
            found[f"encoder + CMA-ES search {amount}"] = (kind, amount)
    for budget in settings.search_from_mean:
        found[f"render search {budget} from the mean preset"] = ("render from mean", budget)
    for index, (name, _) in enumerate(settings.compare):
        found[name] = ("other encoder", index)
    return found


def photo_region(on_a, reference: np.ndarray):
    """(reference, its region mask): what a photo fit reads of a reference on source A (the lips or the hair)."""
    return reference, on_a.bound.mask


def check_settings(settings: EvalSettings) -> None:
    """Bad settings are one-line errors before anything renders."""
    if settings.n < 1:
        raise VtoError(f"--n must be at least 1, got {settings.n}")
    if not 8 <= settings.res <= 4096 or not 1 <= settings.samples <= 65536:
        raise VtoError(f"--res must be in [8, 4096] and --samples in [1, 65536], got {settings.res} and "
                       f"{settings.samples}")
    if settings.seed < 0:
        raise VtoError(f"--seed must be >= 0, got {settings.seed}")
    if any(budget < 1 for budget in settings.search_from_mean):
        raise VtoError(f"--search-from-mean budgets must be >= 1, got {list(settings.search_from_mean)}")
    if any(kind == "imitator" for kind, _ in methods(settings).values()) and not settings.imitator:
        raise VtoError("--refine imitator:K needs --imitator RUN")
    names, builtin = [name for name, _ in settings.compare], methods(replace(settings, compare=()))
    if len(set(names)) != len(names) or any(name in builtin for name in names):
        raise VtoError(f"--compare names must be unique and differ from the built-in methods, got {names}")


def other_sessions(settings: EvalSettings, session: EncoderSession) -> list[EncoderSession]:
    """The --compare encoders, each checked to estimate the same values (its own encoding of them may differ) from the
    same input size as `session`."""
    others = []
    for name, path in settings.compare:
        other = EncoderSession(path)
        if not other.spec.same_values(session.spec) or tuple(other.input_size) != tuple(session.input_size):
            raise VtoError(f"--compare {name}: {path} estimates other values or input size than the evaluated model")
        others.append(other)
    return others


def run_eval(model: str, out: str, settings: EvalSettings) -> dict:
    """Run the transfer experiment; writes results.json, results.md, psnr.png, errors.png and sheet.png to `out`.

    Returns the summary: per method, PSNR/SSIM/perceptual mean and std, ms per reference, parameter errors, buckets.
    """
    from tqdm import tqdm

    from blender_addon.matching.match import SourceRenderer
    from blender_addon.matching.colour_fit import fit_photo_fast
    from blender_addon.matching.photo_fit import iter_fit_photo
    from blender_addon.matching.refine import SIGMA_FROM_MEAN, drain, refine_by_render
    from vto_core.photo.photo_light import light_of, neutral_photo

    from .match import imitator_inputs, imitator_refiner

    check_settings(settings)
    session = EncoderSession(model)
    spec = session.spec
    others = other_sessions(settings, session)
    compared = methods(settings)
    names = list(compared)
    out_dir = Path(out)
    if out_dir.exists() and not out_dir.is_dir():
        raise VtoError(f"--out {out_dir} is a file, not a folder")
    presets = load_presets(spec.renderer)
    preset_units = preset_matrix(spec, presets)
    sampler = ParamSampler(spec, preset_units, 0.5, SEED_BASE + settings.seed)
    mean_unit = preset_units.mean(axis=0).astype(np.float64)
    mean_values = spec.values(spec.denormalise(mean_unit))
    wraps = np.array([p.wraps for p in spec.modelled_params])

    def unit_values(u: np.ndarray) -> dict[str, float]:
        return spec.values(spec.denormalise(u))

    refiner = imitator_refiner(spec, settings.imitator) if any(k == "imitator" for k, _ in compared.values()) else None
    meter = PerceptualMeter()
    # Warm-ups: first calls (imports, allocations) are not a match's cost.
    session.predict(np.zeros((*session.input_size, 3), np.float32))
    import cma  # noqa: F401
    if refiner is not None:
        blank = np.zeros((*refiner.image_size, 3), np.float32)
        refiner.refine(blank, blank, np.full(spec.size, 0.5), 1)

    rows, sheet = [], []
    progress = tqdm(range(settings.n), desc="eval", unit="look", disable=settings.quiet, dynamic_ncols=True,
                    mininterval=0.25 if sys.stderr.isatty() else 30.0)
    for index in progress:
        unit = sampler.sample_unit(index)
        values = spec.values(spec.denormalise(unit))
        source_a, source_b, cycles_seed = SOURCE_BASE + 2 * index, SOURCE_BASE + 2 * index + 1, index

        # Everything on source A first (the reference and what each method renders there), then B.
        started = time.perf_counter()
        on_a = SourceRenderer(spec.renderer, source_a, settings.res, settings.samples, cycles_seed, settings.lighting)
        source_ms = 1000 * (time.perf_counter() - started)  # hair: the source render every A-side method needs
        reference = on_a(values)
        if settings.search_seed_offset:
            started = time.perf_counter()
            on_a = SourceRenderer(spec.renderer, source_a, settings.res, settings.samples,
                                  cycles_seed + settings.search_seed_offset, settings.lighting)
            source_ms = 1000 * (time.perf_counter() - started)
        estimates, ms = {"mean preset": mean_values}, {"mean preset": 0.0}

        started = time.perf_counter()
        estimates["encoder"] = session.predict(reference)[0]
        ms["encoder"] = 1000 * (time.perf_counter() - started)
        encoder_unit = spec.normalise(spec.vector(estimates["encoder"]))

        started = time.perf_counter()
        distances = {name: mse(on_a(spec.full_values(p)), reference) for name, p in presets.items()}
        nearest = min(distances, key=distances.get)
        estimates["nearest preset"] = spec.full_values(presets[nearest])
        ms["nearest preset"] = source_ms + 1000 * (time.perf_counter() - started)

        for name, (kind, amount) in list(compared.items())[3:]:
            started = time.perf_counter()
            if kind == "imitator":
                x, target = imitator_inputs(refiner, spec.renderer, source_a, reference, settings.samples, cycles_seed,
                                            settings.lighting)
                found = refiner.refine(x, target, encoder_unit, amount)
                spent_before = ms["encoder"]
            elif kind == "photo":  # as a photo goes through `vto match`: lips with the light read and taken out
                region = photo_region(on_a, reference)
                encoder = {k: estimates["encoder"][k] for k in spec.modelled}
                if get_product(spec.renderer).face_region is not None:  # the light read from the skin beside it
                    read = neutral_photo(reference, light_of(*region))
                    region = (read, region[1])
                    encoder = {k: v for k, v in session.predict(read)[0].items() if k in spec.modelled}
                fast = fit_photo_fast(spec, region, encoder, quality=amount)[0]
                estimates[name] = spec.full_values(fast if amount == "FAST" else drain(iter_fit_photo(
                    spec, region, encoder, amount, settings.res, settings.samples, others=(fast,))))
                ms[name] = ms["encoder"] + 1000 * (time.perf_counter() - started)
                continue
            elif kind == "other encoder":
                estimates[name] = others[amount].predict(reference)[0]
                ms[name] = 1000 * (time.perf_counter() - started)
                continue
            elif kind in ("render", "cma"):
                found = refine_by_render(lambda u: on_a(unit_values(u)), reference, encoder_unit, amount,
                                         cycles_seed, wraps, search="fit" if kind == "render" else "cma")
                spent_before = ms["encoder"] + source_ms
            else:  # from the mean preset, far from most looks: the derivative-free search, with a wide first step
                found = refine_by_render(lambda u: on_a(unit_values(u)), reference, mean_unit, amount, cycles_seed,
                                         wraps, sigma=SIGMA_FROM_MEAN, search="cma")
                spent_before = source_ms
            estimates[name] = unit_values(found.unit)
            ms[name] = spent_before + 1000 * (time.perf_counter() - started)

        on_b = SourceRenderer(spec.renderer, source_b, settings.res, settings.samples, cycles_seed, settings.lighting)
        truth = on_b(values)
        row = {"index": index, "source_a": source_a, "source_b": source_b, "cycles_seed": cycles_seed,
               "truth": {k: values[k] for k in spec.modelled}, "buckets": buckets(spec, values, unit),
               "nearest_preset": nearest, "methods": {}}
        images = [reference, truth]
        for name in names:
            on_truth_source = on_b(estimates[name])
            errors = parameter_errors(spec, unit, spec.normalise(spec.vector(estimates[name])))
            row["methods"][name] = {
                "psnr": psnr(on_truth_source, truth), "ssim": ssim(on_truth_source, truth),
                "perceptual": meter(on_truth_source, truth), "ms": ms[name],
                "param_error": dict(zip(spec.modelled, errors.round(6).tolist())),
                "raw_error": dict(zip(spec.modelled, raw_errors(spec, values, estimates[name]).round(6).tolist())),
                "estimate": {k: round(float(estimates[name][k]), 5) for k in spec.modelled},
            }
            images.append(on_truth_source)
        rows.append(row)
        if len(sheet) < settings.sheet_rows:
            sheet.append(np.concatenate(images, axis=1))

    summary = summarise(spec, rows, names)
    perceptual_note = (f"perceptual distance: VGG16 features ({meter.distance.weights_path})" if meter.distance else
                       "perceptual distance: not measured, no VGG16 weights (looked at "
                       f"{', '.join(str(p) for p in meter.looked_at)})")
    out_dir.mkdir(parents=True, exist_ok=True)
    settings_record = {k: v for k, v in asdict(settings).items() if k != "quiet"}
    _atomic_write(out_dir / "results.json", json.dumps({
        "model": str(model), "renderer": spec.renderer, "modelled": list(spec.modelled), "settings": settings_record,
        "perceptual": perceptual_note, "sheet_columns": ["reference (A)", "truth (B)", *names],
        "summary": summary, "looks": rows}, indent=1))
    _atomic_write(out_dir / "results.md", markdown(spec, summary, settings, model, perceptual_note))
    write_image(out_dir / "sheet.png", np.concatenate(sheet, axis=0))
    plots(spec, rows, names, out_dir)
    return summary


def _atomic_write(path: Path, text: str) -> None:
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(text)
    temporary.replace(path)


def _mean_std(values: list) -> list[float] | None:
    values = [v for v in values if v is not None]
    return [float(np.mean(values)), float(np.std(values))] if values else None


def summarise(spec: RendererSpec, rows: list[dict], methods: list[str]) -> dict:
    """Per method: PSNR, SSIM, perceptual [mean, std], PSNR median, ms per reference, per-parameter errors (mean of
    the unit error, median of the raw one), PSNR gain over the mean preset with its standard error, and PSNR [mean,
    looks] per bucket."""
    summary = {}
    baseline = np.array([row["methods"]["mean preset"]["psnr"] for row in rows])
    for method in methods:
        results = [row["methods"][method] for row in rows]
        per_bucket: dict[str, list[float]] = {}
        for row, result in zip(rows, results):
            for bucket in row["buckets"]:
                per_bucket.setdefault(bucket, []).append(result["psnr"])
        psnrs = np.array([r["psnr"] for r in results])
        summary[method] = {
            "psnr": _mean_std(psnrs.tolist()), "psnr_median": float(np.median(psnrs)),
            "gain_over_mean_preset_db": float(np.mean(psnrs - baseline)),
            "gain_standard_error_db": standard_error(psnrs - baseline),
            "ssim": _mean_std([r["ssim"] for r in results]),
            "perceptual": _mean_std([r["perceptual"] for r in results]),
            "ms_per_reference": float(np.mean([r["ms"] for r in results])),
            "param_error": {n: float(np.mean([r["param_error"][n] for r in results])) for n in spec.modelled},
            "raw_error_median": {n: float(np.median([r["raw_error"][n] for r in results])) for n in spec.modelled},
            "psnr_by_bucket": {k: [float(np.mean(v)), len(v)] for k, v in sorted(per_bucket.items())},
            "colour_error_median": colour_errors(spec, rows, method),
        }
    return summary


def standard_error(values: np.ndarray) -> float | None:
    """The standard error of the mean of `values` (n,), over looks drawn at random: their sample standard deviation
    over sqrt(n); None for fewer than two. A gain is paired with the mean preset look by look, so the spread of the
    looks' difficulty cancels and only that of the differences counts."""
    values = np.asarray(values, np.float64)
    return float(np.std(values, ddof=1) / np.sqrt(values.size)) if values.size > 1 else None


def colour_errors(spec: RendererSpec, rows: list[dict], method: str) -> dict | None:
    """The median |error| of a method's makeup colour in 8-bit steps, red, green and blue pooled, over all looks and
    over those whose true coverage (Product.coverage: the opacity) is >= OPAQUE (where the colour shows); None for a
    spec that does not model it and the colour."""
    coverage = get_product(spec.renderer).coverage
    if not coverage or not {coverage, *COLOUR} <= set(spec.modelled):
        return None

    def pooled(chosen):
        errors = [row["methods"][method]["raw_error"][c] for row in chosen for c in COLOUR]
        return float(np.median(errors)) if errors else None

    opaque = [row for row in rows if row["truth"][coverage] >= OPAQUE]
    return {"all": pooled(rows), "opaque": pooled(opaque), "opaque_looks": len(opaque)}


def mean_std_text(pair: list[float] | None, digits: int) -> str:
    """[mean, std] as 'mean ± std' to `digits` decimals; 'n/a' for None."""
    return f"{pair[0]:.{digits}f} ± {pair[1]:.{digits}f}" if pair else "n/a"


def gain_text(summary: dict) -> str:
    """A method's gain over the mean preset, dB, and its standard error where there is one: '+7.49 ± 1.21'."""
    error = summary.get("gain_standard_error_db")
    return f"{summary['gain_over_mean_preset_db']:+.2f}" + ("" if error is None else f" ± {error:.2f}")


def seed_words(offset: int) -> str:
    """How results.md names the Cycles seed of the renders methods make on source A."""
    return ("the reference's Cycles seed (its noise shared)" if offset == 0 else
            f"the reference's Cycles seed + {offset} (noise of its own, as against a photo)")


def markdown(spec: RendererSpec, summary: dict, settings: EvalSettings, model: str, perceptual_note: str) -> str:
    """results.md: the transfer table, parameter errors and per-bucket PSNR."""
    methods = list(summary)
    lines = [f"# Transfer evaluation of {Path(model).name} ({spec.renderer}: {', '.join(spec.modelled)})", "",
             f"{settings.n} sampled looks (eval seed {settings.seed}), {settings.res} px, {settings.samples} spp; each "
             "estimated from its render on source A and compared on source B with the truth's Cycles seed "
             f"(paper 7.2.1); what methods render on A uses {seed_words(settings.search_seed_offset)}. "
             f"{perceptual_note}. The gain over the mean preset is given ± its standard error over the looks.", "",
             "| method | PSNR dB (mean ± std) | PSNR median | gain over mean preset dB | SSIM (mean ± std) "
             "| perceptual | ms per reference |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {m} | {mean_std_text(s['psnr'], 2)} | {s['psnr_median']:.2f} | {gain_text(s)} "
              f"| {mean_std_text(s['ssim'], 4)} | {mean_std_text(s['perceptual'], 4)} | {s['ms_per_reference']:.1f} |"
              for m, s in summary.items()]
    header = "| parameter | " + " | ".join(methods) + " |"
    rule = "|---|" + "---|" * len(methods)
    lines += ["", "Mean absolute parameter error (fraction of each range; hue on the circle):", "", header, rule]
    lines += [f"| {n} | " + " | ".join(f"{summary[m]['param_error'][n]:.3f}" for m in methods) + " |"
              for n in spec.modelled]
    units = {p.name: p.unit or "raw" for p in spec.modelled_params}
    lines += ["", "Median absolute parameter error in each parameter's own units:", "", header, rule]
    lines += [f"| {n} ({units[n]}) | " + " | ".join(f"{summary[m]['raw_error_median'][n]:.3g}" for m in methods)
              + " |" for n in spec.modelled]
    colour = {m: summary[m]["colour_error_median"] for m in methods}
    if all(colour.values()):
        looks = colour[methods[0]]["opaque_looks"]

        def cell(value):
            return "-" if value is None else f"{value:.1f}"

        lines += ["", "Median colour error, 8-bit sRGB steps, red, green and blue pooled:", "",
                  "| looks | " + " | ".join(methods) + " |", rule,
                  f"| all ({settings.n}) | " + " | ".join(cell(colour[m]["all"]) for m in methods) + " |",
                  f"| opacity >= {OPAQUE} ({looks}) | " + " | ".join(cell(colour[m]["opaque"]) for m in methods)
                  + " |"]
    seen = sorted({b for m in methods for b in summary[m]["psnr_by_bucket"]})
    lines += ["", "PSNR by bucket (dB mean, looks): dark shades, high gloss, each range's extremes (unit < 0.1 "
                  "'low', > 0.9 'high'):", "", "| bucket | " + " | ".join(methods) + " |", rule]
    for bucket in seen:
        cells = [summary[m]["psnr_by_bucket"].get(bucket) for m in methods]
        lines.append(f"| {bucket} | " + " | ".join(f"{c[0]:.2f} ({c[1]})" if c else "-" for c in cells) + " |")
    lines += ["", "ms per reference: wall time from the reference image to the estimate (the encoder's run, the "
                  "renders on the reference's source that a method makes, refinement steps); the evaluation's own "
                  "renders on B are not counted.", "",
              "sheet.png, per row: reference on A | truth on B | " + " | ".join(f"{m} on B" for m in methods) + "."]
    return "\n".join(lines) + "\n"


def plots(spec: RendererSpec, rows: list[dict], methods: list[str], out_dir: Path) -> None:
    """psnr.png (PSNR box plot per method) and errors.png (mean parameter error per method, with standard errors)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(max(6.0, 1.1 * len(methods)), 4))
    axis.boxplot([[row["methods"][m]["psnr"] for row in rows] for m in methods], tick_labels=methods)
    axis.set_ylabel("transfer PSNR on source B (dB)")
    axis.tick_params(axis="x", labelrotation=25, labelsize=7)
    figure.tight_layout()
    figure.savefig(out_dir / "psnr.png", dpi=100)
    plt.close(figure)
    figure, axis = plt.subplots(figsize=(max(7.0, 0.9 * spec.size * len(methods) ** 0.5), 4))
    width = 0.8 / len(methods)
    for k, method in enumerate(methods):
        errors = np.array([[row["methods"][method]["param_error"][n] for n in spec.modelled] for row in rows])
        axis.bar(np.arange(spec.size) + k * width, errors.mean(0), width, yerr=errors.std(0) / np.sqrt(len(rows)),
                 label=method, capsize=2)
    axis.set_xticks(np.arange(spec.size) + 0.4 - width / 2, spec.modelled, rotation=30)
    axis.set_ylabel("mean |error| (fraction of range)")
    axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out_dir / "errors.png", dpi=100)
    plt.close(figure)
