"""Parameter values from the command line: inline JSON, a JSON file, preset:NAME or preset:NAME@PRESETS.json."""

from __future__ import annotations

import json
from pathlib import Path

from .errors import VtoError
from .presets import load_presets


def parse_params(text: str | None, renderer: str) -> dict[str, float]:
    """'{"red": 200}', a path to such a JSON file, 'preset:Classic Red' or 'preset:Red@out/presets.json' -> values.

    preset:NAME@FILE reads NAME from a presets file of the shipped format (e.g. `vto batch`'s presets.json).
    """
    if not text:
        return {}
    if text.startswith("preset:"):
        name, at, path = text[len("preset:"):].rpartition("@")
        if not at:
            name, path = path, None
        presets = load_presets(renderer, path)
        if name not in presets:
            where = f" in {path}" if path else f"; see `vto presets {renderer}`"
            raise VtoError(f"no {renderer} preset '{name}'{where}")
        return presets[name]
    if text.lstrip().startswith("{"):
        source, raw = "--params", text
    else:
        path = Path(text)
        if not path.is_file():
            raise VtoError(f"--params is neither JSON, preset:NAME nor an existing file: {text}")
        source, raw = str(path), path.read_text()
    try:
        values = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise VtoError(f"{source} is not valid JSON: {exc}") from None
    if isinstance(values, dict) and isinstance(values.get("params"), dict):
        values = values["params"]
    if not isinstance(values, dict):
        raise VtoError(f"{source} must hold an object of parameter values")
    return values
