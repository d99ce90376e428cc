"""Training configs as dataclasses: defaults from the paper, overridable by a JSON file and --set key=value."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, fields
from pathlib import Path

from vto_core.errors import VtoError


@dataclass
class CommonConfig:
    """Options shared by both training runs."""

    steps: int = 20000  # optimiser steps (the paper trains 300 epochs of 15,000 samples)
    batch_size: int = 16
    lr: float = 5e-5
    beta1: float = 0.5
    beta2: float = 0.999
    perceptual: str = "auto"  # auto | vgg | ssim_l1
    vgg_weights: str = ""  # torchvision vgg16 state dict; empty: $VTO_VGG16_WEIGHTS, then $TORCH_HOME/hub/checkpoints
    device: str = "cpu"
    seed: int = 0
    val_fraction: float = 0.1  # held-out share of the dataset (last samples by index)
    log_every: int = 10
    checkpoint_every: int = 200
    num_workers: int = 0  # DataLoader workers


@dataclass
class ImitatorConfig(CommonConfig):
    """Imitator I(X, g) with critic D (paper 5, 6.2): L = l1 * L_imitation + l2 * L_sens + L_GAN."""

    width: int = 64
    n_down: int = 2
    n_res: int = 6
    critic_width: int = 64
    critic_layers: int = 4
    lambda_imitation: float = 100.0
    lambda_sens: float = 1000.0
    lambda_gp: float = 10.0
    use_sensitivity: bool = True  # ablation: imitation | imitation+sensitivity
    use_gan: bool = True
    critic_steps: int = 1  # critic updates per imitator update


@dataclass
class EncoderConfig(CommonConfig):
    """Encoder E (paper 5.3): L = L_graphics + l3 * L_rendering through the frozen imitator."""

    width: int = 32
    n_layers: int = 4
    pool_size: int = 4  # spatial size before the linear head (1 = global average pooling)
    lambda_rendering: float = 20.0
    loss: str = "both"  # ablation: graphics | rendering | both


def _convert(kind, text: str):
    if kind in (bool, "bool"):
        if text.lower() in ("1", "true", "yes", "on"):
            return True
        if text.lower() in ("0", "false", "no", "off"):
            return False
        raise ValueError(f"not a boolean: {text}")
    return {"int": int, "float": float, "str": str}.get(kind, kind)(text)


def resolve_config(cls, config_file: str | None = None, overrides: list[str] | None = None):
    """Defaults <- JSON file <- 'key=value' overrides; unknown keys and bad values are VtoErrors."""
    values = {}
    if config_file:
        try:
            values.update(json.loads(Path(config_file).read_text()))
        except FileNotFoundError:
            raise VtoError(f"no config file at {config_file}") from None
        except json.JSONDecodeError as exc:
            raise VtoError(f"config file {config_file} is not JSON: {exc}") from None
    types = {f.name: f.type for f in fields(cls)}
    for item in overrides or []:
        key, sep, text = item.partition("=")
        if not sep:
            raise VtoError(f"--set takes key=value, got '{item}'")
        if key not in types:
            raise VtoError(f"unknown setting '{key}' for {cls.__name__}; known: {', '.join(types)}")
        try:
            values[key] = _convert(types[key], text)
        except ValueError as exc:
            raise VtoError(f"--set {item}: {exc}") from None
    unknown = set(values) - set(types)
    if unknown:
        raise VtoError(f"unknown setting(s) {', '.join(sorted(unknown))} for {cls.__name__}")
    for key, value in values.items():  # a JSON file's values: "false" or 2.5 steps are errors, not surprises
        _check_type(key, types[key], value)
    config = cls(**values)
    validate(config)
    return config


def _check_type(key: str, kind, value) -> None:
    """A setting's value must have its field's type (an int is a fine float; a bool is not an int)."""
    kind = {"bool": bool, "int": int, "float": float, "str": str}.get(kind, kind)
    if kind is bool:
        fits = isinstance(value, bool)
    elif kind in (int, float):
        fits = isinstance(value, (int, float) if kind is float else int) and not isinstance(value, bool)
    else:
        fits = isinstance(value, kind)
    if not fits:
        raise VtoError(f"setting '{key}' must be a {kind.__name__}, got {value!r}")


def validate(config) -> None:
    """Ranges that would otherwise fail deep inside a run."""
    for name in ("steps", "batch_size", "log_every", "checkpoint_every"):
        if getattr(config, name) < 1:
            raise VtoError(f"{name} must be at least 1, got {getattr(config, name)}")
    if config.lr <= 0:
        raise VtoError(f"lr must be positive, got {config.lr}")
    if not 0.0 <= config.val_fraction < 1.0:
        raise VtoError(f"val_fraction must be in [0, 1), got {config.val_fraction}")
    if config.perceptual not in ("auto", "vgg", "ssim_l1"):
        raise VtoError(f"perceptual must be auto, vgg or ssim_l1, got '{config.perceptual}'")
    if isinstance(config, EncoderConfig) and config.loss not in ("graphics", "rendering", "both"):
        raise VtoError(f"encoder loss must be graphics, rendering or both, got '{config.loss}'")


def config_dict(config) -> dict:
    """JSON-ready dict of a config (what is saved beside checkpoints)."""
    return dataclasses.asdict(config)
