"""Training configs as dataclasses: defaults from the paper, overridable by a preset or JSON file and --set key=value.

The paper's full setting (section 6.2) is the default optimiser: Adam, lr 5e-5 constant, batch 16; its length is
`--config paper` (300 epochs). `--config cpu` is the faster setting measured on a small CPU run
(benchmarks/results/training.md): a higher lr with cosine decay reaches a lower validation error in the same time.

Why hand-written and not tyro/jsonargparse: the settings are flat dataclasses of bool/int/float/str, and the ~60 lines
below already give typed parsing, one-line errors (VtoError, exit 2) and JSON files; a library would add a dependency
(and its own error format) to the Blender-side install for no behaviour the project needs.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, fields
from pathlib import Path

from vto_core.errors import VtoError


@dataclass
class CommonConfig:
    """Options shared by both training runs."""

    steps: int = 20000  # optimiser steps; ignored when epochs > 0
    epochs: int = 0  # > 0: passes over the training split instead (the paper: 300 epochs of 15,000 samples)
    batch_size: int = 16  # global batch: split evenly over the processes of a torchrun job
    lr: float = 5e-5
    schedule: str = "constant"  # constant (the paper) | cosine (decays to 0 at the last step)
    warmup_steps: int = 0  # linear warm-up from 0 to lr over the first steps
    beta1: float = 0.5
    beta2: float = 0.999
    perceptual: str = "auto"  # auto | vgg | ssim_l1
    vgg_weights: str = ""  # torchvision vgg16 state dict; empty: $VTO_VGG16_WEIGHTS, then $TORCH_HOME/hub/checkpoints
    device: str = "cpu"
    seed: int = 0
    val_fraction: float = 0.1  # held-out share of the looks (the last by index; of each folder, or see val_split)
    val_split: str = "each"  # each: that share of every --data folder; tail: of the folders together (before 2026-11-29)
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
    lambda_imitation: float = 100.0  # the paper's lambda_1
    lambda_sens: float = 1000.0  # the paper's lambda_2 (see training.losses.sensitivity_loss for the scale)
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
    blocks: int = 0  # extra 3x3 convolutions per level
    batch_norm: bool = False
    input_filter: int = 0  # read the image box-filtered over this many pixels square (odd, >= 3; 0: as it is)
    lambda_rendering: float = 20.0
    loss: str = "both"  # ablation: graphics | rendering | both
    graphics_error: str = "squared"  # squared (the paper) | absolute: the graphics loss's per-parameter error
    absolute_parameters: str = ""  # 'name,...': these take the absolute error whatever graphics_error says
    parameter_weights: str = ""  # 'name=weight,...' on the graphics loss (e.g. red=4,green=4,blue=4); others weigh 1
    augment: bool = False  # mirrored and shifted views of each render (training/data.augment)
    photo_views: bool = False  # what photos show and renders do not: tilt, zoom, blur, sensor noise (data.photo_views)
    mouth_views: bool = False  # lips: open mouths with teeth and skin texture (data.open_mouths, data.skin_texture)
    init: str = ""  # start from this exported encoder's weights (.onnx of the same network and spec): fine-tuning
    colour_imitator: str = ""  # an exported colour imitator (.onnx, the data's spec) for the colour loss
    lambda_colour: float = 0.0  # the colour loss: what the estimate shows on the default lips against the truth's


@dataclass
class ColourConfig:
    """The colour imitator (training/train_colour.py): an MLP of `width` from parameters to region statistics."""

    steps: int = 4000
    batch_size: int = 256
    lr: float = 3e-3  # cosine decay to 0
    width: int = 128
    val_fraction: float = 0.1
    limit: int = 0  # looks read from each dataset (0: all)
    skin: bool = False  # lipstick: also read the skin around the lips (the imitator is then skin-conditioned)
    seed: int = 0


# Named settings for --config NAME (a JSON file path works too). The paper's schedule is the defaults' optimiser
# run for 300 epochs; "cpu" is measured in benchmarks/results/training.md (bench_training --schedules).
PRESETS = {
    "paper": {"lr": 5e-5, "batch_size": 16, "schedule": "constant", "warmup_steps": 0, "epochs": 300},
    "cpu": {"lr": 2e-3, "batch_size": 16, "schedule": "cosine", "warmup_steps": 50},
}
PRESET_CLASSES = {"cpu": ("EncoderConfig",)}  # presets measured for some networks only
_CHOICES = {"perceptual": ("auto", "vgg", "ssim_l1"), "schedule": ("constant", "cosine"),
            "loss": ("graphics", "rendering", "both"), "graphics_error": ("squared", "absolute"),
            "val_split": ("each", "tail")}


def _convert(kind, text: str):
    if kind in (bool, "bool"):
        if text.lower() in ("1", "true", "yes", "on"):
            return True
        if text.lower() in ("0", "false", "no", "off"):
            return False
        raise ValueError(f"not a boolean: {text}")
    return {"int": int, "float": float, "str": str}.get(kind, kind)(text)


def resolve_config(cls, config_file: str | None = None, overrides: list[str] | None = None):
    """Defaults <- a preset (PRESETS) or JSON file <- 'key=value' overrides; unknown keys, bad values: VtoError."""
    values = {}
    if config_file in PRESETS:
        if cls.__name__ not in PRESET_CLASSES.get(config_file, (cls.__name__,)):
            raise VtoError(f"preset '{config_file}' is measured for {', '.join(PRESET_CLASSES[config_file])} only")
        values.update(PRESETS[config_file])
    elif config_file:
        try:
            loaded = json.loads(Path(config_file).read_text())
        except FileNotFoundError:
            raise VtoError(f"no config file at {config_file} (presets: {', '.join(PRESETS)})") from None
        except json.JSONDecodeError as exc:
            raise VtoError(f"config file {config_file} is not JSON: {exc}") from None
        if not isinstance(loaded, dict):
            raise VtoError(f"config file {config_file} must hold one JSON object of settings")
        values.update(loaded)
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
        article = "an" if kind is int else "a"
        raise VtoError(f"setting '{key}' must be {article} {kind.__name__}, got {value!r}")


def validate(config) -> None:
    """Ranges that would otherwise fail deep inside a run (or silently do nothing)."""
    minimums = {"steps": 1, "batch_size": 1, "log_every": 1, "checkpoint_every": 1, "epochs": 0, "warmup_steps": 0,
                "num_workers": 0, "critic_steps": 1, "width": 1, "critic_width": 1, "critic_layers": 1,
                "n_layers": 1, "pool_size": 1, "blocks": 0, "n_down": 0, "n_res": 0, "limit": 0}
    for name, minimum in minimums.items():
        if hasattr(config, name) and getattr(config, name) < minimum:
            raise VtoError(f"{name} must be at least {minimum}, got {getattr(config, name)}")
    if not 0 < config.lr < math.inf:
        raise VtoError(f"lr must be positive and finite, got {config.lr}")
    for name in ("beta1", "beta2"):
        if hasattr(config, name) and not 0.0 <= getattr(config, name) < 1.0:
            raise VtoError(f"{name} must be in [0, 1), got {getattr(config, name)}")
    for name in ("lambda_imitation", "lambda_sens", "lambda_gp", "lambda_rendering", "lambda_colour"):
        if hasattr(config, name) and not getattr(config, name) >= 0:
            raise VtoError(f"{name} must be at least 0, got {getattr(config, name)}")
    if not 0.0 <= config.val_fraction < 1.0:
        raise VtoError(f"val_fraction must be in [0, 1), got {config.val_fraction}")
    for name, choices in _CHOICES.items():
        if hasattr(config, name) and getattr(config, name) not in choices:
            raise VtoError(f"{name} must be one of {', '.join(choices)}, got '{getattr(config, name)}'")


def with_epochs(config, n_train: int):
    """The config with `steps` from `epochs` when epochs > 0: ceil(epochs x n_train / batch_size)."""
    if config.epochs == 0:
        return config
    batch = min(config.batch_size, n_train)
    return dataclasses.replace(config, steps=max(1, math.ceil(config.epochs * n_train / batch)))


def config_dict(config) -> dict:
    """JSON-ready dict of a config (what is saved beside checkpoints)."""
    return dataclasses.asdict(config)


def data_record(data) -> str | list[str]:
    """The --data folder (or folders) as a run's saved config holds them: one as a string, several as a list."""
    folders = [str(data)] if isinstance(data, (str, Path)) else [str(folder) for folder in data]
    return folders[0] if len(folders) == 1 else folders
