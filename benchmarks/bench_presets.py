"""Each expert preset rendered on fresh default sources and matched by an encoder: does the shade come back?

For every lipstick preset: renders on default-scene sources --first .. --first + --sources - 1 (64 px, 16 spp,
the lighting asked for), the encoder's estimate of each, and the per-channel |error| of red, green and blue in 8-bit
steps. Reported per preset (the median estimate and median error over its sources) and over all presets (the median
of every channel error), per model, into benchmarks/results/presets.md.

--roughness R,... renders every preset again with its Gloss Roughness (not modelled: an encoder can only learn to
look past it, from data made with `vto dataset --vary gloss_roughness`) set to each R, and reports how far the
estimates move: the median channel error over all presets, and Classic Red's estimate, at each R, in the section
roughness-NAME.

    python -m benchmarks.bench_presets --model NAME=blender_addon/models/lipstick_encoder.onnx [--lighting portrait]
    python -m benchmarks.bench_presets --model NAME=MODEL.onnx --roughness 0.05,0.3,0.6,0.9
"""

from __future__ import annotations

import argparse
import json
import shlex
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, lip_colour, table, write_section


def match_presets(model: str, sources: range, lighting: str | None, res: int = 64,
                  overrides: dict[str, float] | None = None) -> dict[str, dict]:
    """preset -> {'set': (3,), 'estimates': (S, 3), 'errors': (S, 3)} for every lipstick preset, rendered with its
    values updated by `overrides`."""
    from blender_addon.renderers.products import render
    from vto_core.inference import EncoderSession
    from vto_core.presets import load_presets

    session = EncoderSession(model)
    found = {}
    for name, values in load_presets("lipstick").items():
        values = {**values, **(overrides or {})}
        truth = lip_colour(values)
        estimates = np.array([lip_colour(session.predict(render("lipstick", values, source, res, 16, 0, lighting))[0])
                              for source in sources])
        found[name] = {"set": truth, "estimates": estimates, "errors": np.abs(estimates - truth)}
    return found


def median_channel_error(found: dict[str, dict]) -> float:
    """The median of every preset's every channel error (match_presets' output)."""
    return float(np.median(np.concatenate([f["errors"].ravel() for f in found.values()])))


def roughness_section(name: str, model: str, roughness: list[float], sources: range, lighting: str,
                      results: Path) -> None:
    """Every preset at each Gloss Roughness: the median channel error and Classic Red's median estimate."""
    rows = []
    for value in roughness:
        found = match_presets(model, sources, lighting, overrides={"gloss_roughness": value})
        overall = median_channel_error(found)
        red = np.median(found["Classic Red"]["estimates"], axis=0)
        rows.append([f"{value:g}", f"{overall:.1f}", "({:.0f}, {:.0f}, {:.0f})".format(*red)])
        print(json.dumps({"model": name, "gloss_roughness": value, "median_channel_error": overall}), flush=True)
    write_section("presets", f"roughness-{name}", (
        f"## {name} ({Path(model).name}) against the coat's roughness, {lighting} lighting\n\n"
        f"Every lipstick preset rendered with its Gloss Roughness set to each value (not modelled; its default is "
        f"0.3, the presets use 0.05-1) on default sources {sources.start}-{sources.stop - 1} (64 px, 16 spp) and "
        f"estimated: the median |error| of R, G and B over all presets, and the median estimate of "
        f"Classic Red (set (190, 20, 35)).\n\n"
        + table(["gloss roughness", "median channel error /255", "Classic Red estimated"], rows)
        + f"\n\nReproduce: `python -m benchmarks.bench_presets --model {shlex.quote(f'{name}={model}')} "
          f"--lighting {lighting} --roughness {','.join(f'{v:g}' for v in roughness)}`."), results=results)


def main() -> None:
    """Match the presets with each --model; write one section per (model, lighting)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", action="append", required=True, metavar="NAME=MODEL.onnx")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"])
    parser.add_argument("--first", type=int, default=9100, help="first default-scene source (none seen in training)")
    parser.add_argument("--sources", type=int, default=4)
    parser.add_argument("--roughness", default="", help="comma-separated Gloss Roughness values to render every "
                                                             "preset at instead (section roughness-NAME)")
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args()
    from blender_addon.renderers.scene_build import DEFAULT_LIGHTING

    lighting = args.lighting or DEFAULT_LIGHTING
    sources = range(args.first, args.first + args.sources)
    for name, model in (item.split("=", 1) for item in args.model):
        if args.roughness:
            roughness_section(name, model, [float(v) for v in args.roughness.split(",")], sources, lighting,
                              Path(args.results))
            continue
        found = match_presets(model, sources, lighting)
        overall = median_channel_error(found)
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
            + f"\n\nReproduce: `python -m benchmarks.bench_presets --model {shlex.quote(f'{name}={model}')} "
              f"--lighting {lighting}`."),
            results=Path(args.results))


if __name__ == "__main__":
    main()
