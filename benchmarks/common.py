"""Shared benchmark helpers: timing and writing result tables."""

from __future__ import annotations

import platform
import time
from pathlib import Path

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


def write_table(name: str, title: str, header: list[str], rows: list[list], notes: str = "") -> Path:
    """Write a markdown table to benchmarks/results/NAME.md and print it."""
    lines = [f"# {title}", "", f"Machine: {platform.processor() or platform.machine()}, {platform.python_version()}; "
             f"written {time.strftime('%Y-%m-%d %H:%M')}.", ""]
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
