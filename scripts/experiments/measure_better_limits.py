"""What limits the lips' Better on studio portraits: presets that no benchmark measures, tried on the London Set's
training people, read back by Fast and by Better, and by Better given what a photo cannot give it.

    PYTHONPATH=. .venv/bin/python scripts/experiments/measure_better_limits.py [--faces 8] [--work out/better_limits]
        [--methods "fast|better|trust 0.25: TRUST_SCALE=0.25|..."]

Products: DEVELOPMENT, 10 presets that are not among bench_skin_tones' products. Faces: the London Set's training
people, neutral (the few not white first). Methods:
  fast, better                 `vto match` as shipped;
  better, true bare            the bare lips under the layer taken from the unmade photo instead of guessed;
  better, true bare, at truth  the same, the fit started at the truth instead of at Fast;
  better, true bare, prior 8   the same from Fast, with a weaker pull towards it (SCENE_PRIOR 8);
  better, bare level 0.2       the bare lips' level fitted beside the product (PhotoLayer.bare_spread 0.2);
  LABEL: NAME=VALUE; ...       Better with constants of blender_addon.matching.photo_scene_fit set (--methods).
Truth and estimates are compared as products: their apparent colour on the default lips (bench_skin_tones.apparent_lab),
CIEDE2000. Every estimate is kept in --work/looks.jsonl (a killed run resumes); prints the median and mean per method.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from benchmarks.bench_skin_tones import FACES, MODEL, ROOT, SAMPLES, apparent_lab, read_back

DEVELOPMENT = ("Rosy Nude", "Caramel Nude", "Mauve", "Brick Red", "Cinnamon", "Wine", "Black Cherry", "Blackened Plum",
               "Velvet Red Matte", "Hot Pink Matte")
METHODS = ("fast", "better", "better, true bare", "better, true bare, at truth", "better, true bare, prior 8",
           "better, bare level 0.2")


def with_method(method: str, bare_photo: np.ndarray, truth: dict[str, float]):
    """Patch Better's fit for `method`; returns a function that undoes it."""
    import blender_addon.matching.photo_scene_fit as fit
    from blender_addon.renderers.sides import blender_side
    from vto_core.colour import srgb_to_linear

    side = blender_side("lipstick")
    saved = (fit.scene_target, fit.bare_guess, fit.iter_fit_photo_scene, fit.SCENE_PRIOR, side.photo_layer)
    target_of, fit_of = fit.scene_target, fit.iter_fit_photo_scene
    true_bare = {}

    def scene_target(photo, found, n):
        target = target_of(photo, found, n)
        bare = target_of(bare_photo, found, n)
        core = fit.lips_core(bare.mask)
        true_bare["colour"] = np.median(srgb_to_linear(bare.frame)[core], axis=0) / np.asarray(bare.layer.core_median)
        return target

    def at_truth(spec, target, start, quality, samples=SAMPLES, seed=0):
        return (yield from fit_of(spec, target, {k: float(truth[k]) for k in spec.modelled}, quality, samples, seed))

    if "true bare" in method:
        fit.scene_target, fit.bare_guess = scene_target, lambda target: true_bare["colour"]
    if "at truth" in method:
        fit.iter_fit_photo_scene = at_truth
    if "prior 8" in method:
        fit.SCENE_PRIOR = 8.0
    if "bare level" in method:
        side.__dict__["photo_layer"] = dataclasses.replace(side.photo_layer, bare_spread=0.2)
    constants = {name: getattr(fit, name) for name in vars(fit) if name.isupper()}
    for setting in method.partition(":")[2].split(";") if ":" in method else ():
        name, value = (part.strip() for part in setting.split("="))
        if name not in constants:
            raise SystemExit(f"photo_scene_fit has no constant {name}")
        setattr(fit, name, type(constants[name])(value))

    def undo():
        fit.scene_target, fit.bare_guess, fit.iter_fit_photo_scene, fit.SCENE_PRIOR = saved[:4]
        for name, value in constants.items():
            setattr(fit, name, value)
        side.__dict__["photo_layer"] = saved[4]
    return undo


def main(argv: list[str] | None = None) -> None:
    from blender_addon.renderers.tryon import tryon_lipstick
    from vto_core.colour import ciede2000
    from vto_core.imageio import read_image, write_image
    from vto_core.presets import load_presets

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=8)
    parser.add_argument("--work", default=str(ROOT / "out" / "better_limits"))
    parser.add_argument("--methods", default="|".join(METHODS), help="'|'-separated methods (see above)")
    args = parser.parse_args(argv)
    work = Path(args.work)
    methods = args.methods.split("|")
    work.mkdir(parents=True, exist_ok=True)
    kept = work / "looks.jsonl"
    rows = {}
    for line in (kept.read_text().splitlines() if kept.is_file() else []):
        row = json.loads(line)
        rows[row["face"], row["product"]] = row
    presets = load_presets("lipstick")
    records = [r for r in json.loads(FACES.read_text()) if r["split"] == "train" and r["expression"] == "neutral"]
    faces = sorted(records, key=lambda r: r["ethnicity"] == "white")[:args.faces]
    for record in faces:
        photo = read_image(ROOT / record["file"])[0]
        for name in DEVELOPMENT:
            row = rows.setdefault((record["file"], name), {"face": record["file"], "product": name,
                                                           "truth": apparent_lab(presets[name]).tolist(), "lab": {}})
            todo = [m for m in methods if m not in row["lab"]]
            if not todo:
                continue
            worn = work / f"{Path(record['file']).stem}_{name.replace(' ', '_')}.png"
            if not worn.is_file():
                write_image(worn, tryon_lipstick(photo, presets[name], samples=SAMPLES))
            for method in todo:
                undo = with_method(method, photo, presets[name])
                try:
                    values = read_back(worn, MODEL, "fast" if method == "fast" else "better")
                finally:
                    undo()
                row["lab"][method] = apparent_lab(values).tolist()
            with kept.open("a") as out:
                out.write(json.dumps(row) + "\n")
        print(f"{record['file']} done", file=sys.stderr, flush=True)
    looks = [r for r in rows.values() if all(m in r["lab"] for m in methods)]
    for method in methods:
        error = [float(ciede2000(np.array(r["truth"]), np.array(r["lab"][method]))) for r in looks]
        print(f"{method:30s} looks {len(looks)}  median CIEDE2000 {np.median(error):.2f}  mean {np.mean(error):.2f}")


if __name__ == "__main__":
    main()
