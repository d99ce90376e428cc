"""The encoder loaded before the first Match (a one-shot timer once a panel shows), and why it cannot load, if so."""

from __future__ import annotations

from pathlib import Path

_status: dict[str, str] = {}  # model path -> "" (loaded) or the one-line reason it cannot load
_pending: set[str] = set()


def problem(model: Path) -> str:
    """Why `model` cannot load ("" when it loaded or has not been tried yet)."""
    return _status.get(str(model), "")


def ensure(model: Path) -> None:
    """Load `model` soon, on the UI thread between redraws (the first Match then finds its session made)."""
    import bpy

    key = str(model)
    if bpy.app.background or key in _status or key in _pending or not Path(key).is_file():
        return
    _pending.add(key)
    bpy.app.timers.register(lambda: load(key), first_interval=0.1)


def load(key: str) -> None:
    """Make the cached session of `key`, remember what went wrong, redraw the panels."""
    import bpy

    from vto_core.inference import cached_session

    _pending.discard(key)
    try:
        cached_session(key)
        _status[key] = ""
    except Exception as exc:  # VtoError (onnxruntime missing or broken, a bad file): the panel shows it
        _status[key] = (str(exc).splitlines() or [type(exc).__name__])[0]
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type in {"PROPERTIES", "NODE_EDITOR"}:
                area.tag_redraw()
    return None


def unregister() -> None:
    _status.clear()
    _pending.clear()
