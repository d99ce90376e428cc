"""How long Find Face on Mesh takes on 2 cores: each test head of data/heads, and heads subdivided to 50,000 vertices
and past, where the time goes.

    python -m benchmarks.bench_find_face [--repeats 3]

Per head: the first call (the face models loaded, as at an artist's first click), then the best of --repeats. The goal
is read on the head nearest GOAL_VERTICES and on the smallest past it. On the largest head, cProfile over one more
call: the functions that take the most time of their own. Writes benchmarks/results/find_face.md.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import time

from benchmarks.common import best_time, write_table
from benchmarks.heads import NAMES, open_head

GOAL_S, GOAL_VERTICES = 3.0, 50_000  # the issue's: at most 3 s on a 50,000-vertex head
SUBDIVIDED = (("lee_perry_smith", 1), ("blender_sculpt", 1), ("lee_perry_smith", 2))  # (head, Catmull-Clark levels)
PROFILED = 8


def subdivided(obj, levels: int):
    """`obj` with its mesh subdivided `levels` times (Catmull-Clark, applied)."""
    import bpy

    modifier = obj.modifiers.new("Subdivide", "SUBSURF")
    modifier.levels = levels
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(obj.evaluated_get(depsgraph))
    obj.modifiers.remove(modifier)
    obj.data = mesh
    return obj


def main(argv: list[str] | None = None) -> None:
    from blender_addon.matching.face_on_mesh import find_face

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    load = os.getloadavg()[0]
    heads = [(name, open_head(name)) for name in NAMES]
    heads += [(f"{name}, subdivided {levels}x", subdivided(open_head(name), levels)) for name, levels in SUBDIVIDED]
    rows, times = [], []
    for label, obj in heads:
        start = time.perf_counter()
        find_face(obj)
        first = time.perf_counter() - start
        best = best_time(lambda obj=obj: find_face(obj), args.repeats)
        rows.append([label, f"{len(obj.data.vertices):,}", f"{first:.2f}", f"{best:.2f}"])
        times.append((len(obj.data.vertices), best))
    profile = cProfile.Profile()
    profile.runcall(find_face, heads[-1][1])
    text = io.StringIO()
    pstats.Stats(profile, stream=text).sort_stats("tottime").print_stats(PROFILED)
    top = [line for line in text.getvalue().splitlines() if line.strip()][-PROFILED:]
    near = min(times, key=lambda t: abs(t[0] - GOAL_VERTICES))
    past = min((t for t in times if t[0] >= GOAL_VERTICES), default=near)
    write_table("find_face", "Find Face on Mesh: seconds on 2 cores", ["head", "vertices", "first call (s)",
                f"best of {args.repeats} (s)"], rows,
                f"Goal: at most {GOAL_S:.0f} s on a head of {GOAL_VERTICES:,} vertices: "
                f"{'met' if max(near[1], past[1]) <= GOAL_S else 'NOT met'} ({near[1]:.2f} s on {near[0]:,}, "
                f"{past[1]:.2f} s on {past[0]:,}). Load average at the start: "
                f"{load:.2f} (a figure taken beside another job is an upper bound). The first call loads the face "
                "models. Most time of its own, on the largest head (cProfile):\n\n```\n" + "\n".join(top) + "\n```")


if __name__ == "__main__":
    main()
