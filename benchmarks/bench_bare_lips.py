"""The bare lips from the skin (vto_core.photo.bare_lips): its coefficients refitted on the training faces of data/faces
that wear no lipstick, and its error on the faces no fit saw.

    python -m benchmarks.bench_bare_lips

Each face is framed as the try-on frames it (64 px, blender_addon.renderers.tryon.photo_lips); the skin is
vto_core.appearance.skin_colour's, the lips their mean linear colour. Writes benchmarks/results/bare_lips.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import delta_e
from benchmarks.common import write_table

ROOT = Path(__file__).resolve().parent.parent
FACES = ROOT / "data" / "faces"


def measured() -> list[tuple[dict, np.ndarray, np.ndarray]]:
    """(entry, skin (3,), lips (3,)) linear, for every face of data/faces wearing no lipstick whose lips are found."""
    from blender_addon.renderers.tryon import photo_lips
    from vto_core.appearance import skin_colour
    from vto_core.colour import srgb_to_linear
    from vto_core.errors import VtoError
    from vto_core.imageio import read_image

    rows = []
    for entry in json.loads((FACES / "faces.json").read_text()):
        if entry.get("lipstick") != "none":
            continue
        try:
            target = photo_lips(read_image(ROOT / entry["file"])[0][..., :3], 64)
        except VtoError:
            continue
        skin = skin_colour(target.frame, target.mask)
        if skin is not None:
            rows.append((entry, skin, srgb_to_linear(target.frame[target.mask > 0.5]).mean(axis=0)))
    return rows


def main() -> None:
    from vto_core.colour import linear_to_srgb, luminance
    from vto_core.photo import bare_lips

    rows = measured()
    train = [r for r in rows if r[0]["split"] == "train"]
    lightness = np.log([float(luminance(skin)) for _, skin, _ in train])
    ratios = np.log([lips / skin for _, skin, lips in train])
    refit = np.array([np.polyfit(lightness, ratios[:, c], 1) for c in range(3)])  # (3, 2): slope, value at 1
    others = [r for r in rows if r[0]["split"] != "train"]
    result = []
    for label, group in (("train (fitted on)", train), ("held out and evaluation", others)):
        errors = [delta_e(linear_to_srgb(bare_lips.bare_lips(skin)), linear_to_srgb(lips)) for _, skin, lips in group]
        same = [delta_e(linear_to_srgb(skin), linear_to_srgb(lips)) for _, skin, lips in group]
        result.append([label, len(group), f"{np.median(errors):.2f}", f"{np.max(errors):.2f}",
                       f"{np.median(same):.2f}"])

    def listed(values) -> str:
        return ", ".join(f"{v:.3f}" for v in values)

    notes = "\n".join([
        f"Refitted slope per channel: {listed(refit[:, 0])} (module: {listed(bare_lips.RATIO_SLOPE)}); value at "
        f"luminance 1: {listed(refit[:, 1])} (module: {listed(bare_lips.RATIO_AT_1)}).",
        "", "Error: CIEDE2000 between the bare lips predicted from the skin and the lips' mean colour. 'skin as lips': "
        "the same against the skin's own colour, what no model gives.",
    ])
    write_table("bare_lips", "The bare lips from the skin",
                ["faces", "count", "median CIEDE2000", "largest", "skin as lips, median"], result, notes)


if __name__ == "__main__":
    main()
