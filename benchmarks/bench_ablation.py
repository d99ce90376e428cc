"""The ablation study (paper Table 1): encoder and imitator losses on one dataset and one budget, per renderer.

Two phases, so the training can run where torch is fast and the evaluation where Blender is:

    python -m benchmarks.bench_ablation train --data DATA --out RUNS [--device cuda] [--imitator-steps N] ...
    python -m benchmarks.bench_ablation eval --runs RUNS [--n 64] [--res 32]

`train` trains two imitators (imitation only; imitation + sensitivity) and four encoders with the same steps and
settings (MIG graphics loss; rendering loss through either imitator; both losses through the sensitivity one) and
exports each encoder to RUNS/<name>.onnx. `eval` runs `vto eval`'s transfer experiment once, every encoder on the
same references, and writes the table into benchmarks/results/ablation.md (one section per renderer).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from benchmarks.common import table, write_section

IMITATORS = {"imitator_imitation": ["use_sensitivity=false"], "imitator_sensitivity": ["use_sensitivity=true"]}
# name -> (encoder loss, imitator run or None, the paper's row labels: encoder loss, imitator loss)
ENCODERS = {
    "mig": ("graphics", None, "graphics loss (MIG)", "-"),
    "rendering_imitation": ("rendering", "imitator_imitation", "rendering loss", "imitation loss"),
    "rendering_sensitivity": ("rendering", "imitator_sensitivity", "rendering loss", "imitation + sensitivity"),
    "both_sensitivity": ("both", "imitator_sensitivity", "graphics + rendering loss", "imitation + sensitivity"),
}


def train(data: str, runs: Path, device: str, imitator_steps: int, encoder_steps: int, extra: list[str]) -> None:
    """Train the two imitators and four encoders (resuming finished ones) and export the encoders."""
    from training.config import EncoderConfig, ImitatorConfig, resolve_config
    from training.export import export_encoder
    from training.train_encoder import train_encoder
    from training.train_imitator import train_imitator

    common = [f"device={device}", "log_every=50", *extra]
    seconds = {}
    for name, settings in IMITATORS.items():
        started = time.perf_counter()
        config = resolve_config(ImitatorConfig, None, [*common, f"steps={imitator_steps}", *settings])
        train_imitator(data, str(runs / name), config)
        seconds[name] = time.perf_counter() - started
    for name, (loss, imitator, _, _) in ENCODERS.items():
        started = time.perf_counter()
        config = resolve_config(EncoderConfig, None, [*common, f"steps={encoder_steps}", f"loss={loss}"])
        run = train_encoder(data, str(runs / imitator) if imitator else None, str(runs / name), config)
        export_encoder(str(run.path), str(runs / f"{name}.onnx"))
        seconds[name] = time.perf_counter() - started
    import torch

    record = {"data": data, "device": device, "gpu": torch.cuda.get_device_name() if device.startswith("cuda") else "",
              "imitator_steps": imitator_steps, "encoder_steps": encoder_steps, "settings": extra,
              "seconds": {k: round(v, 1) for k, v in seconds.items()}}
    (runs / "ablation.json").write_text(json.dumps(record, indent=1))
    print(json.dumps(record))


def evaluate(runs: Path, n: int, res: int, samples: int) -> None:
    """Every encoder on the same references; the table into benchmarks/results/ablation.md."""
    from pipeline.evaluate import EvalSettings, run_eval
    from vto_core.inference import EncoderSession

    record = json.loads((runs / "ablation.json").read_text())
    first, *others = ENCODERS
    settings = EvalSettings(n=n, res=res, samples=samples, compare=tuple((name, str(runs / f"{name}.onnx"))
                                                                        for name in others))
    summary = run_eval(str(runs / f"{first}.onnx"), str(runs / "eval"), settings)
    summary[first] = summary.pop("encoder")
    renderer = EncoderSession(str(runs / f"{first}.onnx")).spec.renderer

    def row(method: str, encoder_loss: str, imitator_loss: str) -> list[str]:
        figures = summary[method]
        perceptual = f"{figures['perceptual'][0]:.3f} ± {figures['perceptual'][1]:.3f}" if figures["perceptual"] \
            else "n/a"
        return [encoder_loss, imitator_loss, f"{figures['psnr'][0]:.2f} ± {figures['psnr'][1]:.2f}",
                f"{figures['ssim'][0]:.3f} ± {figures['ssim'][1]:.3f}", perceptual,
                f"{sum(figures['param_error'].values()) / len(figures['param_error']):.3f}"]

    rows = [row(name, label, imitator) for name, (_, _, label, imitator) in ENCODERS.items()]
    rows += [row(name, name, "-") for name in ("mean preset", "nearest preset")]
    write_section("ablation", f"ablation-{renderer}", (
        f"## {renderer}: encoder and imitator losses (paper Table 1)\n\n"
        f"Data: `{record['data']}`; imitators {record['imitator_steps']} steps, encoders {record['encoder_steps']} "
        f"steps each, settings {record['settings'] or 'defaults'}; trained on {record['gpu'] or record['device']} "
        f"(seconds per run: {record['seconds']}). Transfer experiment (`vto eval`): {n} fresh looks rendered on "
        f"source A, estimated, re-rendered on source B with the truth's Cycles seed; {res} px, {samples} spp. "
        f"Mean ± std over looks; the last column is the mean absolute parameter error (unit range).\n\n"
        + table(["encoder loss", "imitator loss", "PSNR dB", "SSIM", "perceptual", "param error"], rows)
        + "\n\nReproduce: `python -m benchmarks.bench_ablation train --data DATA --out RUNS [--device cuda]`, then "
          f"`python -m benchmarks.bench_ablation eval --runs RUNS --n {n} --res {res}`."))


def main() -> None:
    """python -m benchmarks.bench_ablation train|eval ..."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="phase", required=True)
    trainer = sub.add_parser("train")
    trainer.add_argument("--data", required=True, help="a `vto dataset --sensitivity` folder")
    trainer.add_argument("--out", required=True)
    trainer.add_argument("--device", default="cpu")
    trainer.add_argument("--imitator-steps", type=int, default=3000)
    trainer.add_argument("--encoder-steps", type=int, default=3000)
    trainer.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="for every run")
    evaluator = sub.add_parser("eval")
    evaluator.add_argument("--runs", required=True)
    evaluator.add_argument("--n", type=int, default=64)
    evaluator.add_argument("--res", type=int, default=32)
    evaluator.add_argument("--samples", type=int, default=16)
    args = parser.parse_args()
    if args.phase == "train":
        train(args.data, Path(args.out), args.device, args.imitator_steps, args.encoder_steps, args.set)
    else:
        evaluate(Path(args.runs), args.n, args.res, args.samples)


if __name__ == "__main__":
    main()
