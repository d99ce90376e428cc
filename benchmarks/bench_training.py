"""Training throughput and encoder inference time; with a dataset, the loss-term and schedule measurements.

    python -m benchmarks.bench_training --device cpu                      # throughput + inference section
    python -m benchmarks.bench_training --loss-terms DATA --steps 300     # imitator terms for several lambda_sens
    python -m benchmarks.bench_training --schedules DATA --steps 1500     # encoder: paper schedule vs faster ones

Each writes its own section of benchmarks/results/training.md and keeps the others. DATA: a small sensitivity
dataset, e.g. `vto dataset lipstick --out DATA --n 512 --seed 5 --res 32 --samples 4 --params red,green,blue,gloss
--sensitivity`.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from benchmarks.common import best_time, table, write_section
from training.config import EncoderConfig, ImitatorConfig, resolve_config
from training.export import export_encoder
from training.losses import PerceptualDistance, graphics_errors
from training.networks import Critic, Encoder, Imitator
from training.run import RunFolder
from training.train_encoder import encoder_losses, train_encoder
from training.train_imitator import imitator_losses, train_imitator
from vto_core.inference import EncoderSession
from vto_core.products import get_spec

SPEC = get_spec("lipstick", "opacity,red,green,blue,gloss,gloss_roughness,reflection")  # paper Table 2


def synthetic_batch(batch: int, res: int, m: int, device: str) -> dict[str, torch.Tensor]:
    """Random tensors shaped like a dataset batch with sensitivity renders."""
    return {"source": torch.rand(batch, 3, res, res, device=device), "render": torch.rand(batch, 3, res, res, device=device),
            "g": torch.rand(batch, m, device=device), "moved_render": torch.rand(batch, m, 3, res, res, device=device),
            "moved_g": torch.rand(batch, m, m, device=device)}


def training_rate(kind: str, width: int, res: int, device: str, steps: int = 3) -> float:
    """Samples/s of full optimiser steps (imitator: critic + imitation + sensitivity + GAN; encoder: both losses)."""
    m = SPEC.size
    batch = synthetic_batch(16, res, m, device)
    if kind == "imitator":
        config = ImitatorConfig(width=width, critic_width=width, device=device, perceptual="ssim_l1")
        imitator, critic = Imitator(m, width).to(device), Critic(width).to(device)
        opt, critic_opt = torch.optim.Adam(imitator.parameters()), torch.optim.Adam(critic.parameters())
        perceptual = PerceptualDistance("ssim_l1").to(device)

        def step():
            _, total = imitator_losses(imitator, critic, critic_opt, perceptual, batch, config)
            opt.zero_grad()
            total.backward()
            opt.step()
    else:
        config = EncoderConfig(width=width, device=device, perceptual="ssim_l1")
        encoder, imitator = Encoder(m, width).to(device), Imitator(m, 16).to(device).eval()
        opt = torch.optim.Adam(encoder.parameters())
        perceptual = PerceptualDistance("ssim_l1").to(device)
        error = graphics_errors(config.graphics_error, config.absolute_parameters, SPEC.modelled)

        def step():
            _, total = encoder_losses(encoder, imitator, perceptual, batch, config, error=error)
            opt.zero_grad()
            total.backward()
            opt.step()
    step()
    if device == "cuda":
        torch.cuda.synchronize()
    start = time.perf_counter()
    for _ in range(steps):
        step()
    if device == "cuda":
        torch.cuda.synchronize()
    return 16 * steps / (time.perf_counter() - start)


def inference_times(res: int) -> tuple[float, float, float]:
    """Encoder (default width) at res: ms per image with onnxruntime and torch eager, and their max |diff|."""
    encoder = Encoder(SPEC.size).eval()
    with tempfile.TemporaryDirectory() as folder:
        run = RunFolder(Path(folder) / "run")
        run.save_checkpoint({"kind": "encoder", "step": 0, "model": encoder.state_dict(), "model_args": encoder.model_args,
                             "spec": SPEC.to_dict(), "image_size": [res, res]})
        result = export_encoder(str(run.path), str(Path(folder) / "encoder.onnx"))
        session = EncoderSession(Path(folder) / "encoder.onnx")
        image = np.random.default_rng(0).random((1, 3, res, res), dtype=np.float32)
        tensor = torch.from_numpy(image)
        onnx_ms = 1000 * best_time(lambda: session.predict_unit_nchw(image), 20)
        with torch.no_grad():
            torch_ms = 1000 * best_time(lambda: encoder(tensor), 20)
    return onnx_ms, torch_ms, result["max_abs_diff"]


def throughput(device: str) -> None:
    """Samples/s of full training steps and encoder inference times -> the 'throughput' section."""
    torch.manual_seed(0)
    rows = []
    for kind, widths in (("imitator", (16, 64)), ("encoder", (32,))):
        for width in widths:
            for res in (64, 128):
                rows.append([kind, width, res, f"{training_rate(kind, width, res, device):.1f}"])
    inference = []
    for res in (64, 128, 256):
        onnx_ms, torch_ms, difference = inference_times(res)
        inference.append([res, f"{onnx_ms:.2f}", f"{torch_ms:.2f}", f"{difference:.1e}"])
    write_section("training", f"throughput-{device}", (
        f"## Training throughput on {device}\n\n"
        + table(["network", "width", "px", "samples/s (batch 16, m = 7)"], rows)
        + "\n\nImitator steps include one critic update with gradient penalty, the imitation loss, the sensitivity "
        "loss (16 x 7 extra imitator passes, batched with the base pass) and the adversarial term; SSIM+L1 stands in "
        "for VGG (no weights here).\n\n## Encoder inference, batch 1 (ms)\n\n"
        + table(["px", "onnxruntime (2 threads)", "torch eager", "max abs diff"], inference)
        + f"\n\nReproduce: `.venv/bin/python -m benchmarks.bench_training --device {device}`."))


TINY_IMITATOR = ["width=8", "n_down=1", "n_res=2", "critic_width=8", "critic_layers=3", "perceptual=ssim_l1",
                 "batch_size=8", "lr=0.001", "schedule=cosine", "val_fraction=0.1"]


def loss_terms(data: str, steps: int, lambdas: list[float]) -> None:
    """Imitator runs that differ only in lambda_sens: each term's magnitude, its share, and held-out errors."""
    rows, first = [], None
    for lambda_sens in lambdas:
        with tempfile.TemporaryDirectory() as folder:
            config = resolve_config(ImitatorConfig, None, TINY_IMITATOR + [
                f"steps={steps}", f"log_every={max(steps // 10, 1)}", f"lambda_sens={lambda_sens}",
                f"use_sensitivity={'true' if lambda_sens > 0 else 'false'}"])
            started = time.perf_counter()
            log = train_imitator(data, str(Path(folder) / "run"), config).read_log()
            seconds = time.perf_counter() - started
        first = first or log[0]
        last = log[-1]
        total = sum(abs(last.get(f"{k}_weighted", 0.0)) for k in ("imitation", "sensitivity", "adversarial"))
        share = {k: 100 * abs(last.get(f"{k}_weighted", 0.0)) / total
                 for k in ("imitation", "sensitivity", "adversarial")}
        rows.append([f"{lambda_sens:g}", f"{last['imitation']:.4f}", f"{last.get('sensitivity', float('nan')):.5f}",
                     f"{last.get('adversarial', float('nan')):.3f}",
                     f"{share['imitation']:.0f} / {share['sensitivity']:.0f} / {share['adversarial']:.0f}",
                     f"{last['val_l1']:.4f}", f"{last['val_imitation']:.4f}", f"{last['val_sensitivity']:.5f}",
                     f"{seconds:.0f}"])
    reader_res = resolve_res(data)
    pixels = 3 * reader_res * reader_res
    write_section("training", "loss-terms", (
        "## Imitator loss terms against lambda_sens (how the defaults were chosen)\n\n"
        f"Tiny imitator ({', '.join(TINY_IMITATOR)}), {steps} steps on `{data}` ({reader_res} px, "
        f"{pixels} values per image). At the first log (step {first['step']}, lambda_sens {lambdas[0]:g}): "
        f"imitation {first['imitation']:.4f}, sensitivity {first.get('sensitivity', float('nan')):.5f}, adversarial "
        f"{first.get('adversarial', float('nan')):.3f}. Terms are unweighted, at the last step; shares are of "
        "|weighted terms| (imitation / sensitivity / adversarial, %); val_* on the held-out 10 %.\n\n"
        + table(["lambda_sens", "imitation", "sensitivity", "adversarial", "share I/S/A %", "val L1",
                 "val imitation", "val sensitivity", "s"], rows)
        + f"\n\nThe sensitivity loss is a mean over pixels (training/losses.py); the paper's sum over pixels is the "
          f"same loss with lambda_sens x {pixels} at this size.\n\nReproduce: `.venv/bin/python -m "
          f"benchmarks.bench_training --loss-terms DATA --steps {steps} "
          f"--lambdas {','.join(f'{v:g}' for v in lambdas)}`."))


def resolve_res(data: str) -> int:
    """The (square) image size of a dataset folder."""
    from vto_core.dataset import DatasetReader

    return int(DatasetReader(data).manifest["res"])


SCHEDULES = {
    "paper: lr 5e-5 constant": ["lr=5e-5"],
    "lr 5e-4 constant": ["lr=5e-4"],
    "lr 1e-3 cosine, 50 warm-up": ["lr=1e-3", "schedule=cosine", "warmup_steps=50"],
    "lr 2e-3 cosine, 50 warm-up (--config cpu)": ["lr=2e-3", "schedule=cosine", "warmup_steps=50"],
    "lr 5e-3 cosine, 50 warm-up": ["lr=5e-3", "schedule=cosine", "warmup_steps=50"],
}


def schedules(data: str, steps: int) -> None:
    """Encoder (graphics loss, default width) runs of equal steps -> held-out parameter MSE per schedule."""
    rows = []
    for name, settings in SCHEDULES.items():
        with tempfile.TemporaryDirectory() as folder:
            config = resolve_config(EncoderConfig, None, settings + [
                "loss=graphics", "pool_size=2", f"steps={steps}", f"log_every={max(steps // 10, 1)}",
                "val_fraction=0.1"])
            started = time.perf_counter()
            log = train_encoder(data, None, str(Path(folder) / "run"), config).read_log()
            seconds = time.perf_counter() - started
        at = {row["step"]: row["val_param_mse"] for row in log}
        rows.append([name, f"{at[min(at, key=lambda s: abs(s - steps // 3))]:.4f}",
                     f"{at[min(at, key=lambda s: abs(s - 2 * steps // 3))]:.4f}", f"{log[-1]['val_param_mse']:.4f}",
                     f"{seconds:.0f}"])
    write_section("training", "schedules", (
        "## Encoder schedules in the same time (graphics loss, default width 32, 4 layers, batch 16)\n\n"
        f"Every run takes the same {steps} steps on `{data}` ({resolve_res(data)} px), so the same compute: the "
        "steps cost the same whatever the lr (wall times differ only by the load of this shared machine). Held-out "
        "parameter MSE (normalised, hue on the circle) at a third, two thirds and the end:\n\n"
        + table(["schedule", f"val MSE @{steps // 3}", f"@{2 * steps // 3}", f"@{steps}", "s"], rows)
        + f"\n\nReproduce: `.venv/bin/python -m benchmarks.bench_training --schedules DATA --steps {steps}`."))


def main() -> None:
    """Throughput (default), or --loss-terms / --schedules on a dataset; each writes its section of training.md."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--loss-terms", metavar="DATA", help="sensitivity dataset for the lambda_sens measurement")
    parser.add_argument("--lambdas", default="0,1000,10000,100000", help="lambda_sens values for --loss-terms")
    parser.add_argument("--schedules", metavar="DATA", help="dataset for the schedule measurement")
    parser.add_argument("--steps", type=int, default=300)
    args = parser.parse_args()
    if args.loss_terms:
        loss_terms(args.loss_terms, args.steps, [float(v) for v in args.lambdas.split(",")])
    if args.schedules:
        schedules(args.schedules, args.steps)
    if not (args.loss_terms or args.schedules):
        throughput(args.device)


if __name__ == "__main__":
    main()
