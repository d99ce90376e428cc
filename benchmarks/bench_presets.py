"""Each expert preset rendered on fresh default sources and matched by an encoder: does the shade come back?

For every lipstick preset: renders on default-scene sources --first .. --first + --sources - 1 (64 px, 16 spp,
the lighting asked for), the encoder's estimate of each, and the per-channel |error| of red, green and blue in 8-bit
steps. Reported per preset (the median estimate and median error over its sources) and over all presets (the median
of every channel error), per model, into benchmarks/results/presets.md.

    python -m benchmarks.bench_presets --model NAME=blender_addon/models/lipstick_encoder.onnx [--lighting portrait]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, lip_colour, table, write_section


def match_presets(model: str, sources: range, lighting: str | None, res: int = 64) -> dict[str, dict]:
    """preset -> {'set': (3,), 'estimates': (S, 3), 'errors': (S, 3)} for every lipstick preset."""
    from blender_addon.commands import render
    from vto_core.inference import EncoderSession
    from vto_core.presets import load_presets

    session = EncoderSession(model)
    found = {}
    for name, values in load_presets("lipstick").items():
        truth = lip_colour(values)
        estimates = np.array([lip_colour(session.predict(render("lipstick", values, source, res, 16, 0, lighting))[0])
                              for source in sources])
        found[name] = {"set": truth, "estimates": estimates, "errors": np.abs(estimates - truth)}
    return found


def main() -> None:
    """Match the presets with each --model; write one section per (model, lighting)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", action="append", required=True, metavar="NAME=MODEL.onnx")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"])
    parser.add_argument("--first", type=int, default=9100, help="first default-scene source (none seen in training)")
    parser.add_argument("--sources", type=int, default=4)
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    from blender_addon.scene_lips import DEFAULT_LIGHTING

    lighting = args.lighting or DEFAULT_LIGHTING
    sources = range(args.first, args.first + args.sources)
    for name, model in (item.split("=", 1) for item in args.model):
        found = match_presets(model, sources, lighting)
        overall = float(np.median(np.concatenate([f["errors"].ravel() for f in found.values()])))
        rows = [[preset, "({:.0f}, {:.0f}, {:.0f})".format(*f["set"]),
                 "({:.0f}, {:.0f}, {:.0f})".format(*np.median(f["estimates"], axis=0)),
                 f"{np.median(f['errors']):.1f}"] for preset, f in found.items()]
        print(json.dumps({"model": name, "lighting": lighting, "median_channel_error": overall}))
        write_section("presets", f"presets-{name}-{lighting}", (
            f"## {name} ({Path(model).name}), {lighting} lighting: median per-channel error {overall:.1f}/255\n\n"
            f"Each of the {len(found)} lipstick presets rendered on default sources {sources.start}-{sources.stop - 1} "
            f"(64 px, 16 spp) and estimated; the median estimate over those sources, and the median |error| of its "
            f"R, G and B in 8-bit steps.\n\n"
            + table(["preset", "set (R, G, B)", "estimated (median)", "median channel error /255"], rows)
            + f"\n\nReproduce: `python -m benchmarks.bench_presets --model {name}={model} --lighting {lighting}`."),
            results=Path(args.results))


if __name__ == "__main__":
    main()
