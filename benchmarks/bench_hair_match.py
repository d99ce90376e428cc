"""What the gray (C) curve after the R, G, B curves costs the hair match: Wasserstein-1 against the swatch."""

from __future__ import annotations

import numpy as np
from scipy.stats import wasserstein_distance
from skimage.exposure import match_histograms

from benchmarks.common import write_table
from blender_addon.hair import load_swatch, render_hair_source
from vto_core.colour import luminance
from vto_core.hair import apply_curves_node, fit_hair_match, swatch_target
from vto_core.histogram import fit_histogram_match
from vto_core.presets import load_presets
from vto_core.specs import get_spec

SOURCES = (1, 2, 3)
RES = 64


def _distances(matched: np.ndarray, target: np.ndarray) -> list[float]:
    """W1 (in 1/255) per channel R, G, B and for gray, between matched hair pixels (n, 3) and the target's (m, 3)."""
    pairs = [(matched[:, c], target[:, c]) for c in range(3)] + [(luminance(matched), luminance(target))]
    return [255 * wasserstein_distance(a, b) for a, b in pairs]


def main() -> None:
    """Compare R, G, B then gray, channels alone (the stage), and scikit-image; writes hair_match.md."""
    swatch = load_swatch()
    spec = get_spec("hair")
    results = {"R, G, B then gray": [], "R, G, B only (the stage)": [], "scikit-image match_histograms": []}
    for source_seed in SOURCES:
        source = render_hair_source(source_seed, RES)
        hair = source.mask > 0.5
        for values in load_presets("hair").values():
            target = swatch_target(swatch, spec.full_values(values)).reshape(-1, 3)
            with_gray = fit_histogram_match(source.rgb, target.reshape(swatch.shape), source.mask, n_points=64)
            stage = fit_hair_match(source.rgb, source.mask, target.reshape(swatch.shape))
            results["R, G, B then gray"].append(_distances(apply_curves_node(source.rgb, with_gray)[hair], target))
            results["R, G, B only (the stage)"].append(_distances(apply_curves_node(source.rgb, stage)[hair], target))
            exact = match_histograms(source.rgb[hair][None], target[None], channel_axis=-1)[0]
            results["scikit-image match_histograms"].append(_distances(exact, target))
    rows = []
    for name, distances in results.items():
        mean = np.mean(distances, axis=0)
        rows.append([name] + [f"{d:.2f}" for d in mean] + [f"{mean.mean():.2f}"])
    write_table(
        "hair_match", "Hair histogram match: Wasserstein-1 to the recoloured swatch (1/255, mean over cases)",
        ["matching", "R", "G", "B", "gray", "mean"], rows,
        f"{len(load_presets('hair'))} presets x sources {SOURCES} of the default hair scene at {RES} px, masked hair "
        "pixels, the LUTs applied as Blender's RGB Curves node tabulates them (vto_core.hair.apply_curves_node). "
        "scikit-image matches each channel exactly (no LUT, no gray). "
        "Reproduce: `.venv/bin/python -m benchmarks.bench_hair_match`.",
    )


if __name__ == "__main__":
    main()
