"""Expert presets: realistic product shades shipped as JSON beside this module."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .errors import VtoError
from .products import get_product
from .specs import RendererSpec

PRESET_DIR = Path(__file__).parent / "presets"


def load_presets(renderer: str, path: str | Path | None = None) -> dict[str, dict[str, float]]:
    """Preset name -> raw parameter values (only the values the preset sets)."""
    path = Path(path or get_product(renderer).presets or PRESET_DIR / f"{renderer}.json")
    try:
        data = json.loads(path.read_text())
        if data["renderer"] != renderer:
            raise VtoError(f"{path} holds {data['renderer']} presets, not {renderer}")
        return {row["name"]: dict(row["params"]) for row in data["presets"]}
    except FileNotFoundError:
        raise VtoError(f"no preset file at {path}") from None
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise VtoError(f"bad preset file {path}: {exc}") from None


def preset_matrix(spec: RendererSpec, presets: dict[str, dict[str, float]]) -> np.ndarray:
    """Normalised modelled values of every preset: (n_presets, spec.size) float32."""
    if not presets:
        raise VtoError(f"no {spec.renderer} presets to fit")
    return spec.normalise(np.stack([spec.vector(values) for values in presets.values()]))
