"""A run folder: resolved config, checkpoints (resume), the loss log (JSONL) and its plot."""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

import torch

from vto_core.dataset import write_text_atomic
from vto_core.errors import VtoError

from .distributed import Processes

CHECKPOINT = "checkpoint.pt"
CONFIG = "config.json"
LOSSES = "losses.jsonl"
PLOT = "losses.png"


class RunFolder:
    """Owns RUN/: config.json, checkpoint.pt, losses.jsonl, losses.png."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise VtoError(f"cannot create run folder {self.path}: {exc.strerror}") from None

    def save_config(self, config: dict) -> None:
        """Write the resolved config (refuses to resume a run made with another one)."""
        path = self.path / CONFIG
        if path.exists():
            saved = json.loads(path.read_text())
            if "val_split" in config and "val_split" not in saved:
                # A run made before val_split was a setting held out the tail; for one folder the two splits are alike.
                saved["val_split"] = "tail" if isinstance(saved.get("data"), list) else config["val_split"]
            # Steps may grow; held_out is a record, not a setting (runs made before it was recorded lack it).
            changed = sorted(k for k in set(saved) | set(config)
                             if k not in ("steps", "held_out") and saved.get(k) != config.get(k))
            if changed:
                raise VtoError(f"{self.path} was trained with other settings ({', '.join(changed)}); use a new --out")
        write_text_atomic(path, json.dumps(config, indent=1, sort_keys=True) + "\n")

    def save_checkpoint(self, state: dict) -> None:
        """Atomically write checkpoint.pt."""
        tmp = self.path / (CHECKPOINT + ".tmp")
        torch.save(state, tmp)
        os.replace(tmp, self.path / CHECKPOINT)

    def load_checkpoint(self, required: bool = False) -> dict | None:
        """The last checkpoint, or None (VtoError if `required`)."""
        path = self.path / CHECKPOINT
        if not path.exists():
            if required:
                raise VtoError(f"{self.path} has no {CHECKPOINT}: train it first")
            return None
        try:
            return torch.load(path, map_location="cpu", weights_only=False)
        except Exception as exc:  # torch raises many kinds for a damaged file
            raise VtoError(f"cannot read {path}: {exc}") from None

    def log(self, step: int, losses: dict[str, float]) -> None:
        """Append one line of losses."""
        with open(self.path / LOSSES, "a") as handle:
            handle.write(json.dumps({"step": step, **losses}) + "\n")

    def truncate_log(self, step: int) -> None:
        """Drop log lines after `step` (a resumed run rewrites them)."""
        path = self.path / LOSSES
        if path.exists():
            kept = [line for line in path.read_text().splitlines() if line and json.loads(line)["step"] <= step]
            write_text_atomic(path, "".join(line + "\n" for line in kept))

    def read_log(self) -> list[dict]:
        """All logged lines."""
        path = self.path / LOSSES
        return [json.loads(line) for line in path.read_text().splitlines() if line] if path.exists() else []

    def plot(self, title: str) -> Path:
        """One small panel per logged loss against the step (log scale where positive) -> losses.png."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        rows = self.read_log()
        names = sorted({k for row in rows for k in row if k not in ("step", "samples_per_s")})
        columns = min(len(names), 3) or 1
        lines = -(-len(names) // columns) or 1
        figure, axes = plt.subplots(lines, columns, figsize=(3.2 * columns, 2.4 * lines), dpi=100, squeeze=False)
        for axis, name in zip(axes.flat, names):
            steps, values = zip(*[(row["step"], row[name]) for row in rows if name in row])
            axis.plot(steps, values)
            if min(values) > 0:
                axis.set_yscale("log")
            axis.set_title(name, fontsize=9)
            axis.tick_params(labelsize=7)
        for axis in list(axes.flat)[len(names):]:
            axis.axis("off")
        figure.suptitle(title, fontsize=10)
        figure.tight_layout()
        path = self.path / PLOT
        figure.savefig(path)
        plt.close(figure)
        return path


def check_finite(step: int, losses: dict[str, torch.Tensor | float]) -> dict[str, float]:
    """Loss values -> floats; stops the run with a clear message on NaN or inf."""
    values = {name: float(value) for name, value in losses.items()}
    bad = {name: value for name, value in values.items() if not math.isfinite(value)}
    if bad:
        raise VtoError(f"training stopped at step {step}: loss {', '.join(f'{k}={v}' for k, v in bad.items())} "
                       "(lower lr, check the data); the last good checkpoint is kept")
    return values



def learning_rate(config, step: int) -> float:
    """The lr of optimiser update `step` (0-based): linear warm-up, then constant (the paper) or cosine to 0."""
    if step < config.warmup_steps:
        return config.lr * (step + 1) / (config.warmup_steps + 1)
    if config.schedule == "cosine":
        span = max(config.steps - config.warmup_steps, 1)
        return config.lr * 0.5 * (1.0 + math.cos(math.pi * (step - config.warmup_steps) / span))
    return config.lr


def progress(total: int, done: int, enabled: bool = True, stream=None):
    """A tqdm bar of optimiser steps on stderr, only on a terminal: logs (SLURM, CI) get no carriage returns."""
    from tqdm import tqdm

    stream = stream if stream is not None else sys.stderr
    return tqdm(total=total, initial=done, unit="step", desc="train", file=stream, dynamic_ncols=True,
                mininterval=0.5, disable=not (enabled and stream.isatty()))


def optimise(run: RunFolder, config, step: int, batches, losses_fn, optimiser, validate, save,
             processes: Processes | None = None, scheduled=()) -> int:
    """The loop both trainers share: losses_fn(batch) -> (log terms, total); NaN stop, log, validate, checkpoint.

    Runs from `step` to config.steps; validate() -> dict of held-out numbers; save(step) writes a checkpoint.
    The lr of `optimiser` and of the `scheduled` ones follows learning_rate(config, step). Under torchrun the
    logged terms are averaged over the processes (so every rank stops together on NaN) and only rank 0 validates,
    logs and saves.
    """
    processes = processes or Processes(device=config.device)
    started, samples_seen, saved_at = time.perf_counter(), 0, None
    with progress(config.steps, step, processes.is_main) as bar:
        while step < config.steps:
            for scheduled_optimiser in (optimiser, *scheduled):
                for group in scheduled_optimiser.param_groups:
                    group["lr"] = learning_rate(config, step)
            batch = next(batches)
            losses, total = losses_fn(batch)
            values = check_finite(step + 1, processes.mean(losses))
            optimiser.zero_grad(set_to_none=True)
            total.backward()
            optimiser.step()
            step += 1
            samples_seen += len(batch["g"]) * processes.world_size
            bar.update(1)
            if step % config.log_every == 0 or step == config.steps:
                values["lr"] = optimiser.param_groups[0]["lr"]
                values["samples_per_s"] = samples_seen / (time.perf_counter() - started)
                if processes.is_main:
                    values.update(validate())
                    run.log(step, values)
                bar.set_postfix(total=f"{values['total']:.4g}", refresh=False)
            if processes.is_main and (step % config.checkpoint_every == 0 or step == config.steps):
                save(step)
                saved_at = step
    if processes.is_main and saved_at != step:
        save(step)
    processes.barrier()
    return step
