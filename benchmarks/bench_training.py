"""Training throughput (samples/s) and encoder inference time: onnxruntime against torch eager, 64-256 px."""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from benchmarks.common import best_time, write_table
from training.config import EncoderConfig, ImitatorConfig
from training.export import export_encoder
from training.losses import PerceptualDistance
from training.networks import Critic, Encoder, Imitator
from training.run import RunFolder
from training.train_encoder import encoder_losses
from training.train_imitator import imitator_losses
from vto_core.inference import EncoderSession
from vto_core.specs import get_spec

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

        def step():
            _, total = encoder_losses(encoder, imitator, perceptual, batch, config)
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


def main() -> None:
    """Writes benchmarks/results/training.md (CPU) or training_cuda.md (--device cuda)."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    torch.manual_seed(0)
    rows = []
    for kind, widths in (("imitator", (16, 64)), ("encoder", (32,))):
        for width in widths:
            for res in (64, 128):
                rows.append([kind, width, res, f"{training_rate(kind, width, res, args.device):.1f}"])
    inference = []
    for res in (64, 128, 256):
        onnx_ms, torch_ms, difference = inference_times(res)
        inference.append([res, f"{onnx_ms:.2f}", f"{torch_ms:.2f}", f"{difference:.1e}"])
    suffix = "" if args.device == "cpu" else f"_{args.device}"
    write_table(
        f"training{suffix}", f"Training throughput on {args.device} ({torch.get_num_threads()} threads)",
        ["network", "width", "px", "samples/s (batch 16, m = 7)"], rows,
        "Imitator steps include one critic update with gradient penalty, the imitation loss, the sensitivity loss "
        "(16 x 7 extra imitator passes) and the adversarial term; SSIM+L1 stands in for VGG (no weights here).\n\n"
        "## Encoder inference, batch 1 (ms)\n\n| px | onnxruntime (2 threads) | torch eager | max abs diff |\n"
        "|---|---|---|---|\n" + "\n".join("| " + " | ".join(str(c) for c in row) + " |" for row in inference)
        + f"\n\nReproduce: `.venv/bin/python -m benchmarks.bench_training --device {args.device}`.",
    )


if __name__ == "__main__":
    main()
