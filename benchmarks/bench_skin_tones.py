"""Products of known colour on faces of every skin tone, under one light: tried on, read back, compared as products.

    python -m benchmarks.bench_skin_tones [--faces N] [--better-every K] [--best-every K] [--compare NAME=MODEL ...]

Faces: the London Set's 39 evaluation people, neutral (data/faces/london: 10 black, 9 east Asian, 10 west Asian, 10
white; one studio, one light, never trained on). Products: PRODUCTS, 14 presets from nude to espresso and black, glosses
and mattes. Each is tried on each face with the try-on renderer (16 spp), written as an 8-bit PNG and read back as
`vto match` reads a photo: Fast (the shipped encoder), Better and Best (on every K-th face of each group), and Fast with each
--compare encoder. The truth and every estimate are compared as products: their apparent colour on the default lips
(sources 0 and 1, blender_addon.matching.photo_fit.apparent_colour), in CIELAB; so copying the photo's colour, or one
answer for every photo, wins nothing. Reported per quality: the slope of the estimate's L* on the truth's, each
product's median L* error and CIEDE2000, each group's median CIEDE2000 and L* bias, and each group's slopes both
ways (scatter from a pull to the middle). A picture
(benchmarks/results/skin_tones_sheet.png): one face per group, each product tried on beside its Fast estimate tried on.
Beside it, a suspect measured where the truth is known without a face: the same products rendered on the default lips
(sources 2-4, source hidden), read by each encoder at the render's exposure and +-0.3 stops (the face looks' camera
augmentation): the L* slope in the encoder's own domain, and how far an exposure moves the estimate.
Every look is kept in --cache (a JSON line each): a killed run resumes where it stopped.
Writes benchmarks/results/skin_tones.md.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

import numpy as np

from benchmarks.common import machine, table

ROOT = Path(__file__).resolve().parents[1]
FACES = ROOT / "data" / "faces" / "london" / "faces.json"
RESULTS = Path(__file__).parent / "results"
MODEL = ROOT / "blender_addon" / "models" / "lipstick_encoder.onnx"
PRODUCTS = ("Bare Nude", "Peach Balm", "Coral Crush", "Rose Satin", "Dusty Rose Matte", "Terracotta", "Classic Red",
            "Cherry Gloss", "Berry Stain", "Chocolate", "Plum", "Burgundy Matte", "Espresso", "Goth Black Matte")
GROUPS = ("black", "east_asian", "west_asian", "white")
SOURCES = (0, 1)  # default-scene sources the products are compared on
SAMPLES = 16
CELL = 96  # px: each cell of the picture


def evaluation_faces(limit: int) -> list[dict]:
    """The evaluation people's neutral portraits, groups interleaved (so a partial run spans the groups)."""
    records = [r for r in json.loads(FACES.read_text()) if r["split"] == "evaluation" and r["expression"] == "neutral"]
    by_group = [[r for r in records if r["group"] == g] for g in GROUPS]
    interleaved = [r for row in zip(*[g + [None] * (10 - len(g)) for g in by_group]) for r in row if r is not None]
    return interleaved[:limit] if limit else interleaved


def apparent_lab(values: dict[str, float]) -> np.ndarray:
    """CIELAB (3,) of a product's apparent colour: its region's mean colour on the default lips, median over SOURCES."""
    from blender_addon.matching.photo_fit import apparent_colour
    from vto_core.colour import srgb_to_lab

    return srgb_to_lab(apparent_colour("lipstick", values, SOURCES)["mean"]).astype(float)


def read_back(path: Path, model: Path, quality: str) -> dict[str, float]:
    """What `vto match` writes for the photo at `path` (all parameters)."""
    from blender_addon.matching.match import match

    return match(str(model), str(path), quality=quality)["params"]


def looks(faces: list[dict], args, cache: Path) -> list[dict]:
    """One row per face and product: the truth's and each method's estimate and apparent CIELAB; cached."""
    from blender_addon.renderers.tryon import tryon_lipstick
    from vto_core.dataset import file_digest
    from vto_core.imageio import read_image, write_image
    from vto_core.presets import load_presets

    presets = load_presets("lipstick")
    done = {}
    if cache.is_file():
        for line in cache.read_text().splitlines():
            row = json.loads(line)
            done[row["face"], row["product"]] = row
    truth_lab = {name: apparent_lab(presets[name]) for name in PRODUCTS}
    # an estimate is kept with its encoder's digest: a method read by another file (a new shipped one) is read again
    digests = {path: file_digest(path) for path in {MODEL, *(Path(model) for _, model in args.compare)}}
    rows = []
    worn_dir = cache.with_suffix("")  # the tried-on photos, beside the cache
    worn_dir.mkdir(parents=True, exist_ok=True)
    for index, record in enumerate(faces):
        photo = None
        for name in PRODUCTS:
            key = (record["file"], name)
            methods = {"fast": (MODEL, "fast")}
            block = index // len(GROUPS)  # one face of each group: every K-th block keeps the groups even
            if args.better_every and block % args.better_every == 0:
                methods["better"] = (MODEL, "better")
            if args.best_every and block % args.best_every == 0:
                methods["best"] = (MODEL, "best")
            methods.update({f"fast ({label})": (Path(model), "fast") for label, model in args.compare})
            row = done.get(key, {"face": record["file"], "group": record["group"], "product": name,
                                 "truth": truth_lab[name].tolist(), "estimates": {}})
            todo = [m for m, (model, _) in methods.items() if m not in row["estimates"]
                    or row["estimates"][m].get("model", digests[model]) != digests[model]]  # none kept: legacy rows
            if todo:
                worn = worn_dir / f"{Path(record['file']).stem}_{name.replace(' ', '_')}.png"
                if not worn.is_file():  # the try-on is seeded: a look's photo is the same in every run
                    if photo is None:
                        photo = read_image(ROOT / record["file"])[0]
                    write_image(worn, tryon_lipstick(photo, presets[name], samples=SAMPLES))
                for method in todo:
                    values = read_back(worn, *methods[method])
                    row["estimates"][method] = {"values": values, "lab": apparent_lab(values).tolist(),
                                                "model": digests[methods[method][0]]}
                with cache.open("a") as out:
                    out.write(json.dumps(row) + "\n")
            # this run's methods alone, each read by its encoder now (a cached row keeps other methods' reads)
            rows.append({**row, "estimates": {m: row["estimates"][m] for m in methods}})
        print(f"{record['file']} done", file=sys.stderr, flush=True)
    return rows


RENDER_SOURCES = (2, 3, 4)  # default-scene sources the products are rendered on and read from (not SOURCES)
STOPS = (-0.3, 0.0, 0.3)


def on_default_renders(encoders: dict[str, Path]) -> dict[str, dict[float, tuple[float, float]]]:
    """encoder -> {stops: (L* slope, mean L* bias)} of the products rendered on RENDER_SOURCES at 64 px, scaled by
    2**stops in linear light, read by the encoder alone and compared as products (apparent_lab)."""
    from blender_addon.renderers.products import render
    from vto_core.colour import linear_to_srgb, srgb_to_linear
    from vto_core.inference import EncoderSession
    from vto_core.presets import load_presets

    presets = load_presets("lipstick")
    sessions = {name: EncoderSession(str(path)) for name, path in encoders.items()}
    found = {name: {stops: ([], []) for stops in STOPS} for name in sessions}
    for product in PRODUCTS:
        truth = apparent_lab(presets[product])[0]
        for source in RENDER_SOURCES:
            image = render("lipstick", presets[product], source, 64, SAMPLES, 0)
            for stops in STOPS:
                shown = linear_to_srgb(np.clip(srgb_to_linear(image) * 2.0 ** stops, 0.0, 1.0)).astype(np.float32)
                for name, session in sessions.items():
                    found[name][stops][0].append(truth)
                    found[name][stops][1].append(apparent_lab(session.predict(shown)[0])[0])
    return {name: {stops: (slope(np.array(t), np.array(e)), float(np.mean(np.array(e) - np.array(t))))
                   for stops, (t, e) in by_stops.items()} for name, by_stops in found.items()}


def slope(truth: np.ndarray, estimate: np.ndarray) -> float:
    """Least-squares slope of estimate on truth."""
    return float(np.polyfit(truth, estimate, 1)[0])


def summarise(rows: list[dict]) -> tuple[list[str], dict[str, dict]]:
    """(the methods, method -> its figures: slope, per product and per group medians)."""
    from vto_core.colour import ciede2000

    methods = sorted({m for r in rows for m in r["estimates"]}, key=lambda m: (m != "fast", m))
    figures = {}
    for method in methods:
        have = [r for r in rows if method in r["estimates"]]
        truth = np.array([r["truth"] for r in have])
        found = np.array([r["estimates"][method]["lab"] for r in have])
        error = np.array([float(ciede2000(t, f)) for t, f in zip(truth, found)])
        bias = found[:, 0] - truth[:, 0]
        products = {name: (float(np.median(bias[[r["product"] == name for r in have]])),
                           float(np.median(error[[r["product"] == name for r in have]])))
                    for name in PRODUCTS if any(r["product"] == name for r in have)}
        in_group = {g: s for g in GROUPS for s in [np.array([r["group"] == g for r in have])] if s.any()}
        groups = {g: (float(np.median(error[s])), float(np.median(bias[s]))) for g, s in in_group.items()}
        pulls = {g: (slope(truth[s, 0], found[s, 0]), slope(found[s, 0], truth[s, 0]))
                 for g, s in {**in_group, "all": np.ones(len(have), bool)}.items() if s.sum() > 2}
        fast = np.array([r["estimates"]["fast"]["lab"] for r in have])  # Fast on the same looks: the dial's measure
        figures[method] = {"looks": len(have), "slope": slope(truth[:, 0], found[:, 0]),
                           "fast_same": (slope(truth[:, 0], fast[:, 0]),
                                         float(np.median([ciede2000(t, f) for t, f in zip(truth, fast)]))),
                           "groups_seen": sorted({r["group"] for r in have}),
                           "chroma_slope": slope(np.hypot(truth[:, 1], truth[:, 2]), np.hypot(found[:, 1], found[:, 2])),
                           "median": float(np.median(error)), "products": products, "groups": groups,
                           "pulls": pulls}
    return methods, figures


OPACITY_BANDS = ((0.0, 0.8), (0.8, 0.96), (0.96, 1.01))
DARK = ("Chocolate", "Espresso", "Burgundy Matte", "Goth Black Matte")


def fast_parameters(rows: list[dict]) -> str:
    """Where Fast's lightness goes, in its parameters: per band of the product's true opacity, the L* slope, median
    |L* error| and the estimate's median opacity; the correlation of opacity error and L* error; the dark products'
    true and estimated (median) opacity and colour."""
    from vto_core.presets import load_presets

    presets = load_presets("lipstick")
    true_opacity = np.array([presets[r["product"]]["opacity"] for r in rows])
    opacity = np.array([r["estimates"]["fast"]["values"]["opacity"] for r in rows])
    truth = np.array([r["truth"][0] for r in rows])
    error = np.array([r["estimates"]["fast"]["lab"][0] for r in rows]) - truth
    bands = [[f"[{low:g}, {high:g})", int(s.sum()), f"{slope(truth[s], truth[s] + error[s]):.2f}",
              f"{np.median(np.abs(error[s])):.1f}", f"{np.median(opacity[s]):.2f}"]
             for low, high in OPACITY_BANDS for s in [(true_opacity >= low) & (true_opacity < high)]]
    names = ("opacity", "red", "green", "blue")
    dark = [[name, " / ".join(f"{presets[name][n]:g}" for n in names),
             " / ".join(f"{v:.2f}" if n == "opacity" else f"{v:.0f}" for n, v in zip(names, np.median(
                 [[r["estimates"]["fast"]["values"][n] for n in names] for r in rows if r["product"] == name], axis=0)))]
            for name in DARK]
    correlation = float(np.corrcoef(opacity - true_opacity, error)[0, 1])
    return "\n".join([
        "## Where Fast's lightness goes, in its parameters", "",
        f"Fast's opacity error and L* error correlate {correlation:+.2f} over the {len(rows)} looks (too little opacity "
        "lets the bare lips show through, lighter).", "",
        table(["true opacity", "looks", "L* slope", "median abs L* error", "Fast's median opacity"], bands), "",
        table(["dark product", "truth: opacity / R / G / B", "Fast (median): opacity / R / G / B"], dark), ""])


def sheet(faces: list[dict], rows: list[dict]) -> np.ndarray:
    """One face per group: per product, its lips tried on | its Fast estimate tried on (CELL x CELL each)."""
    from blender_addon.renderers.tryon import tryon_view
    from vto_core.imageio import read_image
    from vto_core.presets import load_presets
    from vto_core.products import LIPSTICK

    presets = load_presets("lipstick")
    estimates = {(r["face"], r["product"]): r["estimates"]["fast"]["values"] for r in rows}
    picture = []
    for record in [next(r for r in faces if r["group"] == g) for g in GROUPS if any(r["group"] == g for r in faces)]:
        photo = read_image(ROOT / record["file"])[0]
        cells = []
        for name in PRODUCTS:
            cells.append(tryon_view(photo, presets[name], CELL, SAMPLES, 0, LIPSTICK)[1])
            cells.append(tryon_view(photo, estimates[record["file"], name], CELL, SAMPLES, 0, LIPSTICK)[1])
            cells.append(np.ones((CELL, 4, 3), np.float32))  # a white gap between products
        picture.append(np.concatenate(cells, axis=1))
    return np.concatenate(picture, axis=0)


def report(methods: list[str], figures: dict, faces: int, argv: list[str], renders: dict, parameters: str) -> str:
    """benchmarks/results/skin_tones.md's text."""
    lines = ["# Products on faces of every skin tone, under one light", "",
             f"`python -m benchmarks.bench_skin_tones {shlex.join(argv)}` on {machine()}: {faces} faces of the London "
             f"Set's evaluation people (never trained on), {len(PRODUCTS)} products tried on each (16 spp), read back "
             "from an 8-bit PNG as `vto match` reads a photo. Truth and estimate are compared as products: their "
             "apparent colour on the default lips (sources 0, 1), CIELAB.", "",
             table(["method", "looks", "groups", "L* slope", "chroma slope", "median CIEDE2000",
                    "Fast on the same looks: L* slope / CIEDE2000"],
                   [[m, figures[m]["looks"], ", ".join(figures[m]["groups_seen"]), f"{figures[m]['slope']:.2f}",
                     f"{figures[m]['chroma_slope']:.2f}", f"{figures[m]['median']:.2f}",
                     "{:.2f} / {:.2f}".format(*figures[m]["fast_same"])] for m in methods]), "",
             "Each product: median L* error (estimate - truth) / median CIEDE2000, per method.", "",
             table(["product"] + methods, [[name] + [
                 "{:+.1f} / {:.1f}".format(*figures[m]["products"][name]) if name in figures[m]["products"] else "-"
                 for m in methods] for name in PRODUCTS]), "",
             "Each group: median CIEDE2000 / median L* bias, per method.", "",
             table(["group"] + methods, [[g] + [
                 "{:.1f} / {:+.1f}".format(*figures[m]["groups"][g]) if g in figures[m]["groups"] else "-"
                 for m in methods] for g in GROUPS]), "",
             "Each group: the L* slope of the estimate on the truth / of the truth on the estimate, per method. "
             "A reader that is right on average whatever it reads (the second slope 1) still has a first slope below "
             "1, by its scatter alone (about the square of their correlation); a second slope above 1 is a pull to "
             "the middle: the estimates' lightness spans too little.", "",
             table(["group"] + methods, [[g] + [
                 "{:.2f} / {:.2f}".format(*figures[m]["pulls"][g]) if g in figures[m]["pulls"] else "-"
                 for m in methods] for g in (*GROUPS, "all")]), "",
             "![each product tried on (left) beside its Fast estimate tried on (right), one face per group]"
             "(skin_tones_sheet.png)", "",
             "## In the encoder's own domain: default renders, source hidden, under another exposure", "",
             f"The {len(PRODUCTS)} products rendered on the default lips (sources {', '.join(map(str, RENDER_SOURCES))},"
             " 64 px, 16 spp), each render also scaled by +-0.3 stops in linear light (the face looks' camera "
             "augmentation), read by the encoder alone: the L* slope and the mean L* bias of the estimate.", "",
             table(["encoder"] + [f"{stops:+.1f} stops: slope / bias" for stops in STOPS],
                   [[name] + ["{:.2f} / {:+.1f}".format(*by_stops[stops]) for stops in STOPS]
                    for name, by_stops in renders.items()]), "", parameters]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=0, help="the first N evaluation faces, groups interleaved (0: all)")
    parser.add_argument("--better-every", type=int, default=1,
                        help="Better on every K-th face of each group (the faces interleave the groups; 0: none)")
    parser.add_argument("--best-every", type=int, default=0, help="Best on every K-th face of each group (0: none)")
    parser.add_argument("--compare", action="append", default=[], type=lambda t: tuple(t.split("=", 1)),
                        help="NAME=MODEL: Fast with another encoder too")
    parser.add_argument("--cache", default=str(ROOT / "out" / "skin_tones.jsonl"))
    parser.add_argument("--no-sheet", action="store_true")
    args = parser.parse_args(argv)
    cache = Path(args.cache)
    cache.parent.mkdir(parents=True, exist_ok=True)
    faces = evaluation_faces(args.faces)
    rows = looks(faces, args, cache)
    methods, figures = summarise(rows)
    renders = on_default_renders({"shipped": MODEL, **{label: Path(model) for label, model in args.compare}})
    RESULTS.mkdir(exist_ok=True)
    if not args.no_sheet:
        from vto_core.imageio import write_image

        write_image(RESULTS / "skin_tones_sheet.png", sheet(faces, rows))
    (RESULTS / "skin_tones.md").write_text(report(methods, figures, len(faces), argv, renders, fast_parameters(rows)))
    print(json.dumps({m: {k: figures[m][k] for k in ("looks", "slope", "median")} for m in methods}))


if __name__ == "__main__":
    main()
