"""The bare lips from the skin (vto_core.photo.bare_lips): its chroma coefficients refitted on the training faces that
wear no lipstick (data/faces and the London Set), and its error on the faces no fit saw.

    python -m benchmarks.bench_bare_lips

Each face is framed as the try-on frames it (64 px, blender_addon.renderers.tryon.photo_lips); the skin is
vto_core.appearance.skin_colour's in the light's own white (the photo's light colour divided out, as Better does), the
lips their mean linear colour. Beside the module's model: the luminance-only model it replaced (fitted on data/faces
alone), refitted here, and the module without its dark-skin knee (DARK_SLOPE 0); each skin group's median L* bias.
Writes benchmarks/results/bare_lips.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import delta_e
from benchmarks.common import table, write_table

ROOT = Path(__file__).resolve().parent.parent
SETS = {"data/faces": ROOT / "data" / "faces" / "faces.json",
        "London Set": ROOT / "data" / "faces" / "london" / "faces.json"}


def measured() -> list[tuple[str, dict, np.ndarray, np.ndarray]]:
    """(set, entry, skin (3,) in the light's white, lips (3,) likewise) linear, for every face of SETS wearing no
    lipstick whose lips are found."""
    from blender_addon.renderers.tryon import photo_lips
    from vto_core.products import LIPSTICK
    from vto_core.appearance import skin_colour
    from vto_core.colour import srgb_to_linear
    from vto_core.errors import VtoError
    from vto_core.imageio import read_image

    rows = []
    for name, records in SETS.items():
        for entry in json.loads(records.read_text()):
            if entry.get("lipstick") != "none":
                continue
            try:
                target = photo_lips(read_image(ROOT / entry["file"])[0][..., :3], LIPSTICK, 64)
            except VtoError:
                continue
            skin = skin_colour(target.frame, target.mask)
            if skin is not None:
                lips = srgb_to_linear(target.frame[target.mask > 0.5]).mean(axis=0)
                rows.append((name, entry, skin / target.cast, lips / target.cast))
    return rows


def luminance_only(train: list):
    """The model before chroma: log r linear in the skin's log luminance alone, fitted on data/faces' `train` rows."""
    from vto_core.photo.bare_lips import lightness

    faces = [r for r in train if r[0] == "data/faces"]
    fit = np.array([np.polyfit([lightness(s) for _, _, s, _ in faces],
                               np.log([lips[c] / s[c] for _, _, s, lips in faces]), 1) for c in range(3)])
    return lambda skin: skin * np.exp(fit[:, 0] * lightness(skin) + fit[:, 1])


def skin_group(entry: dict) -> str:
    """The London Set's ethnicity, or data/faces' skin tone."""
    return entry.get("ethnicity") or f"data/faces {entry.get('skin')}"


def without_knee(skin: np.ndarray) -> np.ndarray:
    """The module's bare lips with DARK_SLOPE 0 (the model before the knee)."""
    from vto_core.photo import bare_lips

    return bare_lips.bare_lips(skin) * np.exp(-bare_lips.DARK_SLOPE * bare_lips.below_knee(skin))


def lightness_bias(model, group: list) -> float:
    """Median L* of the predicted bare lips minus the lips' over `group`'s rows."""
    from vto_core.colour import linear_to_srgb, srgb_to_lab

    return float(np.median([srgb_to_lab(linear_to_srgb(model(skin)))[0] - srgb_to_lab(linear_to_srgb(lips))[0]
                            for _, _, skin, lips in group]))


def main() -> None:
    from vto_core.colour import linear_to_srgb
    from vto_core.photo import bare_lips

    rows = measured()
    train = [r for r in rows if r[1]["split"] == "train"]
    design = np.array([bare_lips.features(skin) for _, _, skin, _ in train])
    held = np.array([np.log(bare_lips.lips_ratio(skin)) - bare_lips.features(skin) @ bare_lips.COEFFICIENTS
                     for _, _, skin, _ in train])  # the luminance slopes kept
    logs = np.log([lips / skin for _, _, skin, lips in train]) - held
    refit = np.linalg.lstsq(design, logs, rcond=None)[0]  # (3, 3)
    before = luminance_only(train)
    result = []
    for name in SETS:
        others = [r for r in rows if r[0] == name and r[1]["split"] != "train"]
        fitted = [r for r in train if r[0] == name]
        for label, group in (("train (fitted on)", fitted), ("held out and evaluation", others)):
            def errors(model):
                return [delta_e(linear_to_srgb(model(skin)), linear_to_srgb(lips)) for _, _, skin, lips in group]

            now = errors(bare_lips.bare_lips)
            result.append([f"{name}, {label}", len(group), f"{np.median(now):.2f}", f"{np.max(now):.2f}",
                           f"{np.median(errors(before)):.2f}", f"{np.median(errors(lambda s: s)):.2f}"])

    by_group = []
    for split in ("train", "other"):
        rows_split = [r for r in rows if (r[1]["split"] == "train") == (split == "train")]
        for group in sorted({skin_group(r[1]) for r in rows_split}):
            members = [r for r in rows_split if skin_group(r[1]) == group]
            by_group.append(["train" if split == "train" else "held out and evaluation", group, len(members),
                             f"{lightness_bias(bare_lips.bare_lips, members):+.1f}",
                             f"{lightness_bias(without_knee, members):+.1f}"])

    def listed(matrix) -> str:
        return "; ".join(", ".join(f"{v:.3f}" for v in row) for row in matrix)

    notes = "\n".join([
        f"Refitted coefficients (rows: 1, log R/G, log B/G; columns R, G, B; the slope on log luminance held at "
        f"{listed([bare_lips.RATIO_SLOPE])}): {listed(refit)} "
        f"(module: {listed(bare_lips.COEFFICIENTS)}).",
        "", "Error: CIEDE2000 between the bare lips predicted from the skin and the lips' mean colour. 'luminance "
        "only': the model before (log r linear in the skin's log luminance, fitted on data/faces alone); 'skin as "
        "lips': the skin's own colour, what no model gives.", "",
        "Each skin group: the median L* bias of the predicted bare lips (a negative bias guesses them darker than "
        "they are), with the dark-skin knee and without it.", "",
        table(["split", "group", "count", "L* bias", "without the knee"], by_group),
    ])
    write_table("bare_lips", "The bare lips from the skin",
                ["faces", "count", "median CIEDE2000", "largest", "luminance only, median", "skin as lips, median"],
                result, notes)


if __name__ == "__main__":
    main()
