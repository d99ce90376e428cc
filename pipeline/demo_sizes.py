"""The budgets of `vto demo --size smoke|small|full`: data, networks, steps and evaluation per size.

Measured on this project's 2-core CPU machine, otherwise idle (every report has its stage timings): `full` 16.6 min
(encoder +5.1 dB transfer PSNR over the mean preset and +4.4 dB over the nearest preset, 24 looks; with 1,500 looks
and 1,500 steps it was 8.5 min and +1.1 dB), `small` 3.9 min (+1.4 dB, 16 looks), `smoke` (CI) 1.3 min (+2.5 dB,
12 looks, 4 parameters). A hair look with a source of its own costs a Cycles render of the hair, the stage alone
~7 ms, so the smoke size's encoder data lets ten hair looks share a source: the hair smoke demo took 1.5 min, not 3.7
(encoder data 22 s, not 152), and its encoder read the same 12 fresh looks at +7.0 dB over the mean preset, not +5.8.
The encoder's rendering loss is weighted 1, not 20: through these small imitators it is ~0.2 against a graphics loss
of ~0.6, so at 20 it would drown the graphics term.

Two datasets at the same size and settings: a small one with sensitivity renders for the
imitator ((m + 2) renders a look), a larger one without for the encoder (2 renders a look), so the encoder sees
several times more looks for the same render time.
"""

from __future__ import annotations

from dataclasses import dataclass

from vto_core.products import get_product

# Settings both trainings share: SSIM+L1 stands in for VGG (CPU time), cosine lr (benchmarks/results/training.md).
COMMON = ["perceptual=ssim_l1", "batch_size=16", "schedule=cosine", "val_fraction=0.1", "log_every=10",
          "checkpoint_every=100"]


@dataclass(frozen=True)
class DemoSize:
    """One budget: dataset sizes and render settings, training overrides (`--set` form), evaluation."""

    res: int
    samples: int  # Cycles spp of every render (datasets and evaluation)
    n_imitator: int  # looks with sensitivity renders (imitator data)
    n_encoder: int  # looks without (encoder data)
    imitator: tuple[str, ...]
    encoder: tuple[str, ...]
    eval_n: int
    refine: tuple[str, ...]
    smoke_params: bool = False  # model the product's smoke_params (a tiny encoder learns them in a minute)
    looks_per_source: int = 1  # encoder data, where the product's looks may share a source render (hair): looks a source

    def source_args(self, renderer: str) -> list[str]:
        """The encoder data's `--looks-per-source`, for products whose looks may share a source render; else none."""
        shares = self.looks_per_source > 1 and get_product(renderer).kind.shared_sources
        return ["--looks-per-source", str(self.looks_per_source)] if shares else []

    def params(self, renderer: str) -> str | None:
        """The --params of the datasets: None for the default spec."""
        return ",".join(get_product(renderer).smoke_params) if self.smoke_params else None


SIZES = {
    "smoke": DemoSize(
        res=32, samples=4, n_imitator=40, n_encoder=300,
        imitator=("width=8", "n_down=1", "n_res=1", "critic_width=8", "critic_layers=2", "steps=60", "lr=0.001"),
        encoder=("width=16", "n_layers=3", "steps=300", "lr=0.002", "warmup_steps=20", "lambda_rendering=1"),
        eval_n=12, refine=("imitator:5",), smoke_params=True, looks_per_source=10),
    "small": DemoSize(
        res=32, samples=8, n_imitator=100, n_encoder=800,
        imitator=("width=8", "n_down=1", "n_res=2", "critic_width=16", "critic_layers=3", "steps=150", "lr=0.001"),
        encoder=("width=32", "steps=800", "lr=0.001", "warmup_steps=50", "augment=true", "lambda_rendering=1"),
        eval_n=16, refine=("imitator:10", "render:8")),
    "full": DemoSize(
        res=64, samples=8, n_imitator=150, n_encoder=4000,
        imitator=("width=8", "n_down=2", "n_res=2", "critic_width=16", "critic_layers=3", "steps=200", "lr=0.001"),
        encoder=("width=32", "steps=4000", "lr=0.001", "warmup_steps=50", "augment=true", "lambda_rendering=1"),
        eval_n=24, refine=("imitator:10", "render:8")),
}
