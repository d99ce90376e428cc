"""How far each face's bare lid is from the guess Better and Best put under the layer (PhotoLayer.bare of the eye
shadow: the cheek below the lid, PhotoLayer.skin, times BARE_LID_RATIO, times LID_CORE_MEDIAN): per lid found, the lid
core's median (linear) over the guess, and over a split's faces the median and the robust spread (interquartile range
/ 1.35) of its log, per channel. The spread is product_eyeshadow.BARE_LID_SPREAD.

    PYTHONPATH=. .venv/bin/python scripts/measure_bare_lid.py [--split train] [--every 1]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    from blender_addon.matching.photo_scene_fit import bare_guess, lips_core, scene_target
    from blender_addon.shipped import photo_reader
    from vto_core.colour import srgb_to_linear
    from vto_core.imageio import read_image
    from vto_core.products import EYESHADOW

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", default="train", help="data/faces/faces.json's split: train, held_out, evaluation")
    parser.add_argument("--every", type=int, default=1, help="every K-th face of the split")
    args = parser.parse_args()
    entries = [e for e in json.loads((ROOT / "data" / "faces" / "faces.json").read_text())
               if e["split"] == args.split][::args.every]
    logs = []
    for entry in entries:
        photo = read_image(ROOT / entry["file"])[0][..., :3]
        found, _ = photo_reader().locate_regions(EYESHADOW, photo)
        ratios = []
        for where in found:
            target = scene_target(photo, where, 64)
            if target is None:
                continue
            guess = np.asarray(bare_guess(target))
            actual = np.median(srgb_to_linear(target.frame)[lips_core(target.mask)], axis=0)
            ratios.append(actual / (guess * np.asarray(target.layer.core_median)))
        logs += [np.log(r) for r in ratios]
        print(f"{entry['subject'][:32]:32s}", " | ".join(" ".join(f"{v:.2f}" for v in r) for r in ratios), flush=True)
    logs = np.array(logs)
    quartiles = np.percentile(logs, [25, 75], axis=0)
    mean_log = logs.mean(axis=1)
    print(f"{len(logs)} lids of {len(entries)} faces: median {np.round(np.exp(np.median(logs, axis=0)), 2)}, robust "
          f"spread of the log {np.round((quartiles[1] - quartiles[0]) / 1.35, 2)} (R, G, B), "
          f"{(np.percentile(mean_log, 75) - np.percentile(mean_log, 25)) / 1.35:.2f} over the channels' mean; 5 % and "
          f"95 % points {np.round(np.exp(np.percentile(mean_log, [5, 95])), 2)} times the guess")


if __name__ == "__main__":
    main()
