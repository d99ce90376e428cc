"""Shared benchmark helpers: timing and writing result tables."""

from __future__ import annotations

import math
import os
import platform
import re
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).parent / "results"


def best_time(fn, repeats: int = 3) -> float:
    """Best wall time of `repeats` calls, in seconds (after one warm-up call)."""
    fn()
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def lip_colour(values: dict[str, float]) -> np.ndarray:
    """The makeup colour of lipstick values: (3,) red, green and blue in 8-bit steps."""
    return np.array([values["red"], values["green"], values["blue"]], np.float64)


def write_table(name: str, title: str, header: list[str], rows: list[list], notes: str = "") -> Path:
    """Write a markdown table to benchmarks/results/NAME.md and print it."""
    lines = [f"# {title}", "", f"Machine: {machine()}; written {time.strftime('%Y-%m-%d %H:%M')}.", ""]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    if notes:
        lines += ["", notes]
    text = "\n".join(lines) + "\n"
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.md"
    path.write_text(text)
    print(text)
    return path


def box_iou(a, b) -> float:
    """Intersection over union of two (x, y, w, h) boxes."""
    ax, ay, aw, ah = a
    bx, by, bw, bh = b
    width = max(0.0, min(ax + aw, bx + bw) - max(ax, bx))
    height = max(0.0, min(ay + ah, by + bh) - max(ay, by))
    inter = width * height
    return float(inter / (aw * ah + bw * bh - inter)) if inter else 0.0


def machine() -> str:
    """One line about this machine: CPU model, cores, Python, and Blender's and torch's versions where they are loaded."""
    import sys

    cpu = platform.processor() or platform.machine()
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                   if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    text = f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"
    if (bpy := sys.modules.get("bpy")) is not None:
        text += f", Blender {bpy.app.version_string} (Cycles on the CPU)"
    if (torch := sys.modules.get("torch")) is not None:
        text += f", torch {torch.__version__} ({torch.get_num_threads()} threads)"
    return text


def table(header: list[str], rows: list[list]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])


def write_section(result: str, name: str, text: str, results: Path = RESULTS) -> None:
    """Replace (or append) section `name` of RESULTS/RESULT.md (benchmarks/results/), between its two markers."""
    path = Path(results) / f"{result}.md"
    old = path.read_text() if path.exists() else f"# {result.capitalize()} benchmarks\n"
    begin, end = f"<!-- {name} -->", f"<!-- /{name} -->"
    block = f"{begin}\n{text.strip()}\n\nMachine: {machine()}; written {time.strftime('%Y-%m-%d %H:%M')}.\n{end}"
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    new = pattern.sub(lambda _: block, old) if pattern.search(old) else old.rstrip() + "\n\n" + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(new)
    print(block)


def tilted(photo: np.ndarray, degrees: float) -> np.ndarray:
    """(H, W, 3) turned `degrees` clockwise about its centre on a canvas grown to hold it (black corners), as a tilted
    selfie (a half turn exactly, by flipping)."""
    import OpenImageIO as oiio

    if degrees == 180:
        return np.ascontiguousarray(photo[::-1, ::-1])
    turned = oiio.ImageBufAlgo.rotate(oiio.ImageBuf(np.ascontiguousarray(photo)), math.radians(degrees),
                                      recompute_roi=True)
    return np.clip(turned.get_pixels(oiio.FLOAT)[..., :3], 0, 1)
