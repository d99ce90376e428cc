"""An experiment on the lightness pull (not shipped): a linear calibration of Fast's estimate, fitted on the London
Set's training people only, judged on the evaluation looks of bench_skin_tones.

    python -m benchmarks.bench_lightness_calibration [--looks-per-face 6] [--ridge 0.01]

(a) Looks drawn by the lipstick sampler (seed 77, not the presets the benchmark measures) are tried on the training
people's neutral portraits and read back by Fast; each (estimate, truth) pair is kept in --cache. (b) A ridge fit maps
the estimate's modelled unit vector to the truth's (u_true = A u_est + b); and the inverse one: the estimate regressed
on the truth (u_est = W u_true + c), inverted (it undoes a pull to the middle instead of adding to it). (c) The calibration is applied to Fast's
cached estimates of bench_skin_tones' evaluation looks (out/skin_tones.jsonl) and compared as products there (apparent
colour on the default lips, sources 0 and 1). Writes the section "calibration" of benchmarks/results/skin_tones.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.bench_skin_tones import FACES, GROUPS, MODEL, PRODUCTS, ROOT, SAMPLES, apparent_lab, read_back, slope
from benchmarks.common import table, write_section

SEED = 77  # the sampler's seed for the training looks


def training_pairs(per_face: int, cache: Path) -> list[dict]:
    """{'face', 'truth': raw values, 'estimate': raw values} for `per_face` sampled looks on each training person."""
    from blender_addon.renderers.tryon import tryon_lipstick
    from vto_core.imageio import read_image, write_image
    from vto_core.presets import load_presets, preset_matrix
    from vto_core.products import get_spec
    from vto_core.sampling import ParamSampler

    spec = get_spec("lipstick")
    sampler = ParamSampler(spec, preset_matrix(spec, load_presets("lipstick")), 0.5, SEED)
    done = [json.loads(line) for line in cache.read_text().splitlines()] if cache.is_file() else []
    seen = {(row["face"], row["index"]) for row in done}
    faces = [r for r in json.loads(FACES.read_text()) if r["split"] == "train" and r["expression"] == "neutral"]
    with tempfile.TemporaryDirectory() as folder:
        for number, record in enumerate(faces):
            photo = None
            for k in range(per_face):
                index = number * per_face + k
                if (record["file"], index) in seen:
                    continue
                photo = read_image(ROOT / record["file"])[0] if photo is None else photo
                truth = spec.full_values(spec.values(sampler.sample(index)))
                worn = Path(folder) / "worn.png"
                write_image(worn, tryon_lipstick(photo, truth, samples=SAMPLES))
                row = {"face": record["file"], "index": index, "truth": truth, "estimate": read_back(worn, MODEL, "fast")}
                done.append(row)
                with cache.open("a") as out:
                    out.write(json.dumps(row) + "\n")
            print(f"{record['file']} done", file=sys.stderr, flush=True)
    return done


def fit(pairs: list[dict], ridge: float):
    """(A (m, m+1)): least squares with a ridge pull towards the identity, unit space of the modelled parameters."""
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    est = np.array([spec.normalise(spec.vector(p["estimate"])) for p in pairs])
    true = np.array([spec.normalise(spec.vector(p["truth"])) for p in pairs])
    design = np.hstack([est, np.ones((len(est), 1))])
    prior = np.hstack([np.eye(spec.size), np.zeros((spec.size, 1))])
    gram = design.T @ design + ridge * len(est) * np.eye(spec.size + 1)
    return np.linalg.solve(gram, design.T @ true + ridge * len(est) * prior.T).T


def inverse_fit(pairs: list[dict]) -> np.ndarray:
    """(m, m+1): the estimate regressed on the truth (unit space), inverted: u_true = W^-1 (u_est - c)."""
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    est = np.array([spec.normalise(spec.vector(p["estimate"])) for p in pairs])
    true = np.array([spec.normalise(spec.vector(p["truth"])) for p in pairs])
    weights = np.linalg.lstsq(np.hstack([true, np.ones((len(true), 1))]), est, rcond=None)[0].T
    inverse = np.linalg.inv(weights[:, :-1])
    return np.hstack([inverse, (-inverse @ weights[:, -1])[:, None]])


def calibrated(matrix: np.ndarray, values: dict[str, float]) -> dict[str, float]:
    """`values` with the modelled ones mapped through the calibration (clipped to their ranges)."""
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    unit = np.clip(matrix @ np.append(spec.normalise(spec.vector(values)), 1.0), 0.0, 1.0)
    return spec.full_values({**values, **spec.values(spec.denormalise(unit))})


def main(argv: list[str] | None = None) -> None:
    from vto_core.colour import ciede2000

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--looks-per-face", type=int, default=6)
    parser.add_argument("--ridge", type=float, default=0.01)
    parser.add_argument("--cache", default=str(ROOT / "out" / "calibration_pairs.jsonl"))
    parser.add_argument("--evaluation", default=str(ROOT / "out" / "skin_tones.jsonl"))
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    pairs = training_pairs(args.looks_per_face, Path(args.cache))
    matrices = {"fast, calibrated (ridge)": fit(pairs, args.ridge), "fast, calibrated (inverse)": inverse_fit(pairs)}
    rows = [json.loads(line) for line in Path(args.evaluation).read_text().splitlines()]
    rows = list({(r["face"], r["product"]): r for r in rows}.values())
    truth = np.array([r["truth"] for r in rows])
    found = {"fast": np.array([r["estimates"]["fast"]["lab"] for r in rows]),
             **{name: np.array([apparent_lab(calibrated(matrix, r["estimates"]["fast"]["values"])) for r in rows])
                for name, matrix in matrices.items()}}
    lines = [f"Linear calibrations of Fast's estimate (unit space; fitted on {len(pairs)} sampled looks tried on the "
             f"training people: the truth regressed on the estimate with ridge {args.ridge}, and the estimate regressed "
             f"on the truth, inverted), applied to Fast's estimates of the {len(rows)} evaluation looks above. An "
             "experiment: not shipped.", ""]
    summary = []
    for method, labs in found.items():
        error = np.array([float(ciede2000(t, f)) for t, f in zip(truth, labs)])
        bias = labs[:, 0] - truth[:, 0]
        products = [float(np.median(bias[[r["product"] == n for r in rows]])) for n in PRODUCTS]
        groups = [float(np.median(bias[[r["group"] == g for r in rows]])) for g in GROUPS]
        summary.append([method, f"{slope(truth[:, 0], labs[:, 0]):.2f}", f"{np.median(error):.2f}",
                        f"{min(products):+.1f} .. {max(products):+.1f}", " ".join(f"{b:+.1f}" for b in groups)])
    lines.append(table(["method", "L* slope", "median CIEDE2000", "product L* errors (median)",
                        "group L* bias (" + ", ".join(GROUPS) + ")"], summary))
    write_section("skin_tones", "calibration", "## A calibration of Fast, fitted on the training people\n\n"
                  + "\n".join(lines))


if __name__ == "__main__":
    main()
