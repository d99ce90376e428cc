"""The lipstick on the photo: a sheet of presets tried on faces, what must not change, what must order, and times.

    python -m benchmarks.bench_tryon [--faces N] [--samples 16]

Faces: the held-out faces of data/faces/faces.json whose lips show (never trained or tuned on), plus scikit-image's
astronaut and matplotlib's Grace Hopper. Products: eight presets from nude to espresso, a high gloss among them.
(a) The sheet (benchmarks/results/tryon_sheet.png): per face, the photo's lips and each product tried on them, and on
the right the product on the default lips (source 0). (b) Outside the lips' soft mask, the largest change of any
pixel (must be 0). (c) Order: the try-on's lips L* against the product's own L* on the default lips (the renderer's
look), as the share of product pairs ordered alike (pairs at least 3 L* apart on the default lips), per face; and the
hue order red < brown, pink < red as CIELAB hue angles. (d) Times (best of 3): a whole 1-megapixel portrait, and a
64 px crop (`vto tryon --crop`).
Writes benchmarks/results/tryon.md.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import load_photo
from benchmarks.common import machine, table

ROOT = Path(__file__).resolve().parents[1]
FACES = ROOT / "data" / "faces" / "faces.json"
RESULTS = Path(__file__).parent / "results"
PRODUCTS = ("Bare Nude", "Rosy Nude", "Baby Pink Gloss", "Rose Satin", "Classic Red", "Berry Stain", "Chocolate",
            "Espresso")
MIN_GAP = 3.0  # L*: product pairs closer than this on the default lips are not counted for order
SHEET_FACES = ("Robert Satcher", "Robert Curbeam", "John Herrington", "Tamara Jernigan", "Lisa Nowak",
               "Dorothy Metcalf-Lindenburger")  # six skin tones and lip colours, for the picture
CELL = (96, 144)  # px (height, width) of each picture cell


def faces(limit: int) -> list[dict]:
    """The held-out faces whose lips show, then the astronaut and Grace Hopper."""
    records = json.loads(FACES.read_text())
    chosen = [r for r in records if r["split"] == "held_out" and r["lips_visible"]]
    chosen += [r for r in records if r["file"].startswith("package:")]
    return chosen[:limit] if limit else chosen


def photo_of(record: dict) -> np.ndarray:
    """A face record's photo (H, W, 3) in [0, 1]."""
    if record["file"].startswith("package:"):
        return load_photo(record, ROOT)
    from vto_core.imageio import read_image

    return read_image(ROOT / record["file"])[0]


def lips_lab(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """CIELAB (3,) of the mean colour inside mask (H, W) > 0.5."""
    from vto_core.colour import srgb_to_lab

    return srgb_to_lab(image[mask > 0.5].mean(axis=0))


def hue(lab: np.ndarray) -> float:
    """CIELAB hue angle in degrees."""
    return math.degrees(math.atan2(lab[2], lab[1]))


def run(records: list[dict], samples: int) -> tuple[list, list, np.ndarray]:
    """(per-face rows, pooled order figures, the sheet)."""
    from blender_addon.matching.photo_fit import apparent_colour
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.renderers.tryon import find_lips, tryon_lipstick
    from vto_core.colour import srgb_to_lab
    from vto_core.imageio import resize
    from vto_core.photo.tryon import feathered
    from vto_core.presets import load_presets
    from vto_core.products import LIPSTICK

    presets = load_presets("lipstick")
    reference = {name: srgb_to_lab(apparent_colour("lipstick", presets[name])["mean"]) for name in PRODUCTS}
    default_lips = [np.pad(resize(render_lipstick(presets[name], 0, 128, samples, 0), CELL[0], CELL[0]),
                           ((0, 0), ((CELL[1] - CELL[0]) // 2,) * 2, (0, 0))) for name in PRODUCTS]
    rows, sheet_rows = [], []
    for record in records:
        photo = photo_of(record)
        lips = find_lips(photo, LIPSTICK)
        reach = feathered(lips.mask) > 0
        x, y, w, h = lips.box
        half_w, half_h = 0.8 * w, 0.8 * w * CELL[0] / CELL[1]
        cx, cy = x + w / 2, y + h / 2
        box = tuple(int(round(v)) for v in (max(0, cy - half_h), min(photo.shape[0], cy + half_h),
                                             max(0, cx - half_w), min(photo.shape[1], cx + half_w)))
        cells, labs, outside = [photo[box[0]:box[1], box[2]:box[3]]], {}, 0.0
        for name in PRODUCTS:
            worn = tryon_lipstick(photo, presets[name], samples=samples)
            outside = max(outside, float(np.abs(worn[~reach] - photo[~reach]).max()))
            labs[name] = lips_lab(worn, lips.mask)
            cells.append(worn[box[0]:box[1], box[2]:box[3]])
        pairs = [(a, b) for i, a in enumerate(PRODUCTS) for b in PRODUCTS[i + 1:]
                 if abs(reference[a][0] - reference[b][0]) >= MIN_GAP]
        agree = sum((reference[a][0] < reference[b][0]) == (labs[a][0] < labs[b][0]) for a, b in pairs) / len(pairs)
        red_browner = hue(labs["Chocolate"]) > hue(labs["Classic Red"])
        pink_bluer = hue(labs["Rose Satin"]) < hue(labs["Classic Red"])
        rows.append([record["subject"].split(",")[0], record["split"], record.get("skin", ""), f"{outside * 255:.2f}",
                     f"{agree:.0%} of {len(pairs)}", "yes" if red_browner else "no", "yes" if pink_bluer else "no",
                     " < ".join(sorted(PRODUCTS, key=lambda n: labs[n][0])[:3]) + " ..."])
        if record["subject"].split(",")[0] in SHEET_FACES:
            sheet_rows.append(np.concatenate([resize(cell, *CELL) for cell in cells], axis=1))
        print(f"{record['subject']} done", file=sys.stderr, flush=True)
    strip = np.concatenate([np.zeros((*CELL, 3), np.float32)] + default_lips, axis=1)
    return rows, [reference], np.concatenate([strip] + sheet_rows, axis=0)


def times(record: dict, samples: int) -> list[list]:
    """Best of 3 (ms): a whole portrait resized to about 1 megapixel, and a 64 px crop."""
    from blender_addon.renderers.tryon import tryon_lipstick
    from vto_core.imageio import resize
    from vto_core.presets import load_presets

    photo = photo_of(record)
    scale = math.sqrt(1.0e6 / (photo.shape[0] * photo.shape[1]))
    photo = resize(photo, round(photo.shape[0] * scale), round(photo.shape[1] * scale))
    values = load_presets("lipstick")["Classic Red"]

    def best(crop):
        tryon_lipstick(photo, values, crop=crop, samples=samples)
        spans = []
        for _ in range(3):
            started = time.perf_counter()
            tryon_lipstick(photo, values, crop=crop, samples=samples)
            spans.append(1000 * (time.perf_counter() - started))
        return min(spans)

    return [[f"whole portrait, {photo.shape[1]}x{photo.shape[0]}", f"{best(None):.0f}"],
            ["64 px crop", f"{best(64):.0f}"]]


def main(argv: list[str] | None = None) -> None:
    from vto_core.imageio import write_image

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=0, help="only the first N faces (0: all)")
    parser.add_argument("--samples", type=int, default=16)
    args = parser.parse_args(argv)
    records = faces(args.faces)
    command = "python -m benchmarks.bench_tryon" + (f" {shlex.join(argv)}" if argv else "")
    timing = times(records[0], args.samples)
    rows, (reference,), sheet = run(records, args.samples)
    write_image(RESULTS / "tryon_sheet.png", sheet)
    order = " < ".join(sorted(PRODUCTS, key=lambda n: reference[n][0]))
    text = (f"# The lipstick on the photo\n\nMachine: {machine()}. Reproduce: `{command}`.\n\n"
            f"Products: {', '.join(PRODUCTS)}. On the default lips (source 0-7, the renderer's own look) their L* "
            f"runs {order}.\n\n![sheet](tryon_sheet.png)\n\n*Top row: each product on the default lips, in the "
            "order listed. Then six faces of different skin tones: the photo's lips (some wear a lipstick of their "
            "own), and each product tried on them (`vto tryon`).*\n\n"
            "Per face: the largest change of any pixel outside the lips' soft mask (in 1/255), the share of product "
            f"pairs (at least {MIN_GAP:g} L* apart on the default lips) whose lightness order the try-on keeps, and "
            "the hue order (CIELAB hue angle): Chocolate browner (larger) than Classic Red, Rose Satin pinker "
            "(smaller) than Classic Red.\n\n"
            + table(["face", "split", "skin", "outside the lips, largest change", "lightness order kept",
                     "brown > red", "pink < red", "darkest three"], rows)
            + "\n\nTimes (ms, best of 3, Cycles on the CPU):\n\n" + table(["try-on", "ms"], timing) + "\n")
    (RESULTS / "tryon.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
