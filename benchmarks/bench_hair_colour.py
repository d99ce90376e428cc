"""Does a hair colour come back? The 22 hair presets and natural black and platinum hair, given as hair regions (what
an artist gives) and matched, Fast and Better; the colour of each estimate against the colour it came from.

    python -m benchmarks.bench_hair_colour [--model blender_addon/models/hair_encoder.onnx] [--sources 4]

Presets: each preset's swatch at full effect (intensity 1, blend -1: a photo shows a colour, not how strongly it was
applied) recolours the hair of --sources fresh default hair regions (seeds 700000 and up, 64 px); each is matched.
The preset's apparent colour and the estimate's are read alike: the median over default hair regions 0-7 of the
hair's mean colour in the stage's output (blender_addon.matching.photo_fit.apparent_colour); the figure is CIEDE2000.
Natural hair: default hair regions rendered with the melanin of black (1.0) and platinum (0.0) hair, no stage: the
raw render is the photo. ΔL* is the estimate's lightness on regions 0-7 minus the photo hair's.
Writes benchmarks/results/hair_colour.md.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, machine, table

MODEL = Path(__file__).resolve().parent.parent / "blender_addon" / "models" / "hair_encoder.onnx"
FRESH = 700000
QUALITIES = ("FAST", "BETTER")
MELANIN = {"black": 1.0, "platinum": 0.0}


def delta_e(a: np.ndarray, b: np.ndarray) -> float:
    from vto_core.colour import ciede2000, srgb_to_lab

    return float(ciede2000(srgb_to_lab(a), srgb_to_lab(b)))


def estimates(session, region: tuple[np.ndarray, np.ndarray], qualities) -> dict[str, tuple[dict, float]]:
    """quality -> (all values, ms): the encoder on the region's largest hair square fitted through the colour imitator
    (Fast), or through the stage from it or the encoder's (Better); as a Match does
    (blender_addon.matching.apply.iter_compute)."""
    from blender_addon.matching.colour_fit import fit_photo_fast
    from blender_addon.matching.photo_fit import iter_fit_photo, photo_values
    from blender_addon.shipped import photo_reader
    from blender_addon.matching.refine import drain

    spec, found = session.spec, {}
    for quality in qualities:
        started = time.perf_counter()
        reference = photo_reader().hair_reference(region[0], mask=region[1])
        encoder = {k: v for k, v in session.predict(reference.image)[0].items() if k in spec.modelled}
        values = photo_values(spec, fit_photo_fast(spec, reference.region, encoder, quality=quality)[0])
        if quality != "FAST":
            values = photo_values(spec, drain(iter_fit_photo(spec, reference.region, encoder, quality,
                                                             others=(values,))))
        found[quality] = (spec.full_values(values), 1000 * (time.perf_counter() - started))
    return found


def natural_region(source: int, melanin: float):
    """A default hair region of `source` with its melanin set: (rgb (64, 64, 3), mask (64, 64))."""
    import bpy

    from blender_addon.renderers.hair import render_hair_source
    from blender_addon.renderers.scene_hair import HAIR_MATERIAL, apply_source, build_hair_scene

    apply_source(build_hair_scene(), source)
    node = bpy.data.materials[HAIR_MATERIAL].node_tree.nodes["Hair BSDF"]
    node.inputs["Melanin"].default_value = melanin
    node.inputs["Tint"].default_value = (1.0, 1.0, 1.0, 1.0)  # undyed
    region = render_hair_source(source, 64, 16)
    return region.rgb, region.mask


def main(argv: list[str] | None = None) -> None:
    """Presets and natural black and platinum, Fast and Better."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default=str(MODEL))
    parser.add_argument("--sources", type=int, default=4)
    args = parser.parse_args(argv)
    from blender_addon.renderers.hair import render_hair_source, run_hair_stage
    from blender_addon.matching.photo_fit import apparent_colour
    from vto_core.hair import PHOTO_HAIR
    from vto_core.appearance import mean_colour
    from vto_core.colour import srgb_to_lab
    from vto_core.inference import EncoderSession
    from vto_core.presets import load_presets

    session = EncoderSession(args.model)
    sources = [FRESH + k for k in range(args.sources)]
    regions = {s: render_hair_source(s, 64, 16) for s in sources}
    rows, errors = [], {q: [] for q in QUALITIES}
    for name, values in load_presets("hair").items():
        full = {**values, **PHOTO_HAIR}
        truth = apparent_colour("hair", full)["mean"]
        per = {q: [] for q in QUALITIES}
        for source, region in regions.items():
            found = estimates(session, (run_hair_stage(region, full), region.mask), QUALITIES)
            for quality, (estimate, _) in found.items():
                per[quality].append(delta_e(truth, apparent_colour("hair", estimate)["mean"]))
        for quality in QUALITIES:
            errors[quality] += per[quality]
        rows.append([name, "(" + ", ".join(f"{v:.0f}" for v in 255 * truth) + ")"]
                    + [f"{np.median(per[q]):.1f}" for q in QUALITIES])
    rows.append(["**all presets (median of every match)**", ""]
                + [f"**{np.median(errors[q]):.1f}**" for q in QUALITIES])

    natural = []
    for colour, melanin in MELANIN.items():
        for source in sources[:2]:
            rgb, mask = natural_region(source, melanin)
            photo = mean_colour(rgb, mask)
            found = estimates(session, (rgb, mask), QUALITIES)
            for quality, (estimate, ms) in found.items():
                shown = apparent_colour("hair", estimate)["mean"]
                natural.append([colour, source, quality, "(" + ", ".join(f"{v:.0f}" for v in 255 * photo) + ")",
                                "(" + ", ".join(f"{v:.0f}" for v in 255 * shown) + ")", f"{delta_e(photo, shown):.1f}",
                                f"{srgb_to_lab(shown)[0] - srgb_to_lab(photo)[0]:+.1f}", f"{ms:,.0f}"])
    command = "python -m benchmarks.bench_hair_colour " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
    text = ["# Hair colour from hair regions", "", f"Machine: {machine()}; written {time.strftime('%Y-%m-%d %H:%M')}.",
            "", f"Reproduce: `{command.strip()}` (model {Path(args.model).name}).", "",
            f"## The {len(rows) - 1} presets, each on {args.sources} fresh default hair regions", "",
            "CIEDE2000 between the preset's apparent colour and the estimate's (both on default hair regions 0-7); "
            "the median over the preset's sources.", "",
            table(["preset", "apparent colour", *[f"ΔE {q.lower()}" for q in QUALITIES]], rows), "",
            "## Natural black and platinum hair (default regions, melanin 1.0 and 0.0, no stage)", "",
            table(["hair", "source", "quality", "photo hair", "estimate on regions 0-7", "ΔE", "ΔL*", "ms"],
                  natural), ""]
    (RESULTS / "hair_colour.md").write_text("\n".join(text))
    print("\n".join(text))


if __name__ == "__main__":
    main()
