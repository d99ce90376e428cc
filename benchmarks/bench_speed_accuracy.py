"""The speed-accuracy trade at match time, measured in one `vto eval` run on one machine (issue 9, item 5).

Methods: mean preset, nearest preset, encoder, encoder + imitator K, encoder + render search B (the fit through the
renderer), encoder + CMA-ES search B, CMA-ES render search from the mean preset, and what a photo gets (the panel's
Fast, Better, Best, with the reference's source hidden: --photo). Writes speed_accuracy.md (table,
machine) and speed_accuracy.png (the Pareto front) into --results.

    .venv/bin/python -m benchmarks.bench_speed_accuracy --model M.onnx --imitator RUN [--n 24] [--res 64]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from benchmarks.common import RESULTS, machine

EMPTY = "''"  # an empty list, as the shell passes one


def pareto(points: list[tuple[float, float, str]]) -> list[tuple[float, float, str]]:
    """The (ms, psnr, name) points no other point beats on both time and PSNR, fastest first."""
    front, best = [], float("-inf")
    for point in sorted(points, key=lambda p: (p[0], -p[1])):
        if point[1] > best:
            front.append(point)
            best = point[1]
    return front


def run(model: str, imitator: str | None, n: int, res: int, samples: int, seed: int, steps: list[int],
        budgets: list[int], from_mean: list[int], results: Path, cma_budgets: tuple[int, ...] = (),
        photo: tuple[str, ...] = ()) -> Path:
    """One eval with every method; the table and the plot land in `results`; returns the table's path."""
    from pipeline.evaluate import EvalSettings, run_eval

    refine = ([f"imitator:{k}" for k in steps] if imitator else []) + [f"render:{b}" for b in budgets]
    refine += [f"cma:{b}" for b in cma_budgets] + [f"photo:{quality}" for quality in photo]
    settings = EvalSettings(n, res, samples, seed, tuple(refine), tuple(from_mean), imitator)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        summary = run_eval(model, folder, settings)
    minutes = (time.perf_counter() - started) / 60
    front = {name for _, _, name in pareto([(s["ms_per_reference"], s["psnr"][0], m) for m, s in summary.items()])}
    rows = sorted(summary.items(), key=lambda item: item[1]["ms_per_reference"])
    lines = ["# Match-time speed and accuracy (transfer experiment)", "",
             f"Machine: {machine()}.", "",
             f"`vto eval` of {Path(model).name}" + (f" with imitator {Path(imitator).name}" if imitator else "") +
             f": {n} sampled looks (eval seed {seed}), {res} px, {samples} spp; written "
             f"{time.strftime('%Y-%m-%d %H:%M')}, {minutes:.1f} min in all.", "",
             "| method | ms per reference | transfer PSNR dB (mean ± std) | gain over mean preset dB | SSIM "
             "| Pareto |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {m} | {s['ms_per_reference']:.1f} | {s['psnr'][0]:.2f} ± {s['psnr'][1]:.2f} | "
              f"{s['gain_over_mean_preset_db']:+.2f} | {s['ssim'][0]:.4f} | {'yes' if m in front else ''} |"
              for m, s in rows]
    lines += ["", "ms per reference: from the reference image to the estimate. The nearest preset renders every preset "
                  "on the reference's source; render search counts its renders there (B, plus the hair source render "
                  "for hair); imitator refinement counts rendering the bare source X and K Adam steps on the CPU.",
              "", "Reproduce: `.venv/bin/python -m benchmarks.bench_speed_accuracy --model " + model +
              (f" --imitator {imitator} --steps {','.join(map(str, steps))}" if imitator else " --steps ''") +
              f" --n {n} --res {res} --samples {samples} --seed {seed} --budgets {','.join(map(str, budgets))}"
              f" --from-mean {','.join(map(str, from_mean)) or EMPTY}"
              + (f" --cma-budgets {','.join(map(str, cma_budgets))}" if cma_budgets else "")
              + (f" --photo {','.join(photo)}" if photo else "") + "`."]
    results.mkdir(parents=True, exist_ok=True)
    table = results / "speed_accuracy.md"
    table.write_text("\n".join(lines) + "\n")
    plot(summary, front, results / "speed_accuracy.png")
    print("\n".join(lines))
    return table


def plot(summary: dict, front: set[str], path: Path) -> None:
    """Transfer PSNR against ms per reference (log), the Pareto front as a dashed staircase."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = sorted((max(s["ms_per_reference"], 0.01), s["psnr"][0], m) for m, s in summary.items())
    figure, axis = plt.subplots(figsize=(7, 4.2))
    for ms, psnr, name in points:
        axis.scatter(ms, psnr, color="k" if name in front else "0.6")
        axis.annotate(name, (ms, psnr), fontsize=7, xytext=(4, 2), textcoords="offset points")
    axis.plot(*zip(*[(ms, psnr) for ms, psnr, name in points if name in front]), "k--", linewidth=0.8,
              drawstyle="steps-post", label="Pareto front")
    axis.set_xscale("log")
    axis.set_xlabel("wall ms per reference (log; the mean preset drawn at 0.01)")
    axis.set_ylabel("transfer PSNR (dB)")
    axis.legend()
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main(argv: list[str] | None = None) -> None:
    """Command line: see the module docstring."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", required=True, help="encoder .onnx")
    parser.add_argument("--imitator", default=None, help="imitator run (for the imitator:K rows)")
    parser.add_argument("--n", type=int, default=24)
    parser.add_argument("--res", type=int, default=64)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--seed", type=int, default=777)
    parser.add_argument("--steps", default="10,50", help="imitator refinement steps K")
    parser.add_argument("--budgets", default="25,100", help="render search budgets B from the encoder")
    parser.add_argument("--cma-budgets", default="", help="CMA-ES search budgets B from the encoder")
    parser.add_argument("--from-mean", default="400", help="CMA-ES render search budgets B from the mean preset")
    parser.add_argument("--photo", default="", help="the panel's qualities with the source hidden: fast,better,best")
    parser.add_argument("--results", default=str(RESULTS), help="folder for speed_accuracy.md and .png")
    args = parser.parse_args(argv)

    def ints(text: str) -> list[int]:
        return [int(v) for v in text.split(",") if v.strip()]

    run(args.model, args.imitator, args.n, args.res, args.samples, args.seed, ints(args.steps), ints(args.budgets),
        ints(args.from_mean), Path(args.results), tuple(ints(args.cma_budgets)),
        tuple(q for q in args.photo.split(",") if q))


if __name__ == "__main__":
    main()
