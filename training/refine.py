"""Gradient refinement at match time: K Adam steps on g in unit space through the frozen imitator I(X, g).

Works on arrays, without bpy: the caller brings the source X and the reference at the imitator's image size
(blender_addon.matching.match renders X; `vto eval` does the same). The objective is the imitator's: the distance
between I(X, g) and the reference, as the encoder's rendering loss measures it (the perceptual distance the imitator was
trained with, VGG features or SSIM+L1), or plain L1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from vto_core.errors import VtoError
from vto_core.specs import RendererSpec

from .losses import PerceptualDistance
from .run import RunFolder
from .train_encoder import load_frozen_imitator

LR = 0.05  # first Adam step in unit space (cosine-decayed to 0 over the K steps)
DISTANCES = ("perceptual", "l1")


@dataclass
class ImitatorRefined:
    """Best unit vector (m,), its objective through the imitator, the objective at the start, steps taken."""

    unit: np.ndarray
    loss: float
    start_loss: float
    steps: int


class ImitatorRefiner:
    """An imitator run, loaded once, frozen, for refining estimates of `spec` (refused if made for another)."""

    def __init__(self, run: str, spec: RendererSpec, distance: str = "perceptual", device: str = "cpu"):
        if distance not in DISTANCES:
            raise VtoError(f"unknown refinement distance '{distance}'; choose from {', '.join(DISTANCES)}")
        if not Path(run).is_dir():  # RunFolder would create it
            raise VtoError(f"--imitator {run}: no imitator run folder there")
        checkpoint = RunFolder(run).load_checkpoint(required=True)
        size = checkpoint.get("image_size")
        self.image_size = (int(size[0]), int(size[1]))
        self.imitator = load_frozen_imitator(run, spec, device, list(self.image_size))
        self.spec, self.device = spec, device
        self.wraps = torch.tensor([p.wraps for p in spec.modelled_params], dtype=torch.bool)
        if distance == "l1":
            self.distance = lambda x, y: (x - y).abs().mean()
            self.distance_name = "l1"
        else:  # the kind the imitator was trained with; 'auto' falls back to SSIM+L1 (loudly) where VGG weights went
            mode = "ssim_l1" if checkpoint.get("perceptual") == "ssim_l1" else "auto"
            self.distance = PerceptualDistance(mode).to(device)
            self.distance_name = self.distance.kind

    def _tensor(self, image: np.ndarray, what: str) -> torch.Tensor:
        """(H, W, 3) at the imitator's size -> (1, 3, H, W) float32, NaN-free and clipped to [0, 1]."""
        image = np.asarray(image, np.float32)
        if image.shape != (*self.image_size, 3):
            raise VtoError(f"{what} is {image.shape}; the imitator works on {self.image_size[0]}x{self.image_size[1]} "
                           "RGB images")
        image = np.clip(np.nan_to_num(image, nan=0.0), 0.0, 1.0)
        return torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1)))[None].to(self.device)

    def _into_box(self, g: torch.Tensor) -> torch.Tensor:
        """(1, m) -> (1, m) in [0, 1]: wrapping dimensions mod 1, the others clamped."""
        return torch.where(self.wraps.to(g.device), torch.remainder(g, 1.0), g.clamp(0.0, 1.0))

    def objective(self, source: np.ndarray, reference: np.ndarray, unit: np.ndarray) -> float:
        """distance(I(X, g), reference) for one unit vector (m,): what refine() minimises."""
        x, y = self._tensor(source, "the source"), self._tensor(reference, "the reference")
        with torch.no_grad():
            g = self._into_box(torch.as_tensor(np.asarray(unit, np.float32))[None].to(self.device))
            return float(self.distance(self.imitator(x, g), y))

    def refine(self, source: np.ndarray, reference: np.ndarray, start: np.ndarray, steps: int,
               lr: float = LR) -> ImitatorRefined:
        """K = `steps` Adam steps on g from `start` (m,); every iterate is brought into [0, 1] (hue wraps).

        source, reference: (H, W, 3) at the imitator's size. The objective of each iterate (the start and the
        point after the last step included) is evaluated before the next step, and the best is returned: never
        worse than the start.
        """
        if steps < 1:
            raise VtoError(f"imitator refinement needs at least 1 step, got {steps}")
        x, y = self._tensor(source, "the source"), self._tensor(reference, "the reference")
        start = np.asarray(start, np.float32).reshape(-1)
        if start.shape != (self.spec.size,):
            raise VtoError(f"the start has {start.size} values; the imitator models {self.spec.size}")
        g = self._into_box(torch.from_numpy(start)[None].to(self.device)).requires_grad_(True)
        optimiser = torch.optim.Adam([g], lr=lr)
        best_unit, best_loss, start_loss = g.detach().clone(), math.inf, None
        for step in range(steps + 1):
            loss = self.distance(self.imitator(x, g), y)
            value = float(loss.detach())
            if not math.isfinite(value):
                raise VtoError(f"imitator refinement: the objective is {value} at step {step}")
            start_loss = value if start_loss is None else start_loss
            if value < best_loss:
                best_unit, best_loss = g.detach().clone(), value
            if step == steps:
                break
            for group in optimiser.param_groups:  # cosine decay: big moves first, settling at the end
                group["lr"] = lr * 0.5 * (1.0 + math.cos(math.pi * step / steps))
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            optimiser.step()
            with torch.no_grad():
                g.copy_(self._into_box(g))
        return ImitatorRefined(best_unit[0].cpu().numpy().astype(np.float64), best_loss, float(start_loss), steps)
