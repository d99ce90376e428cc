"""The lipstick encoder on real faces: products tried on held-out portraits and read back, the lightness and chroma
read from real photos, and the photo's lips alone changed (issue "An encoder that has seen real faces").

    python -m benchmarks.bench_photo_sources [--model NEW.onnx] [--compare OLD.onnx]
        [--parts roundtrip,slopes,sweep,picture,exposure] [--qualities fast] [--faces 13] [--products 16]

(a) roundtrip: each of PRODUCTS tried on each held-out face of data/faces (`vto tryon`'s renderer, the whole photo),
    read back by `vto match` (its own path, blender_addon.matching.match.match); truth and estimate rendered on
    default sources 0-7 (64 px, 16 spp): the PSNR of the renders, and CIEDE2000 between their apparent colours (the
    median over the sources of the lips' mean colour, blender_addon.matching.photo_fit.apparent_colour).
(b) slopes: the 16 NASA portraits of benchmarks/photos (all but the astronaut and Grace Hopper): the photo's lips as
    Match reads them (mean over the lips found, the light taken out) against the estimate's apparent colour on
    sources 0-1; the least-squares slope of estimate on photo, for L* and for chroma C*.
(b2) sweep: every portrait of benchmarks/photos with its lips' L* (or C*) moved by -20..+20 inside the lips found,
    the rest of the photo untouched; the slope of the estimate's L* (C*) on the lips' for each portrait. Beside it the
    same sweep on the default scene's own renders (SWEEP_PRESETS x sources 0-1, read by the encoder as Match reads a
    render). Each model is measured on both.
(d) picture: the held-out faces as they are, each model's Fast estimate tried on them and on the default lips.
(e) exposure: why (b)'s lightness slope and the re-lit portraits pull apart. Every portrait of benchmarks/photos
    re-lit as `bench_light --part photos` re-lights it (two white balances, +-0.7 EV); the skin's L* against the lips'
    across faces and under an exposure, and an estimate whose L* is pulled a share k of the way to the photo lips'
    L*: (b)'s slope against the re-lit portraits' CIEDE2000 from the photo as it is (new model, Fast, sources 0-7).
--compare: today's encoder (default: the one shipped at COMPARE_COMMIT, taken from git) gives the comparison rows.
Writes benchmarks/results/photo_sources.md (a section per part) and photo_sources.png.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import delta_e
from benchmarks.common import RESULTS, table, write_section
from vto_core.metrics import psnr

ROOT = Path(__file__).resolve().parent.parent
FACES = ROOT / "data" / "faces"
PHOTOS = ROOT / "benchmarks" / "photos" / "photos.json"
MODEL = ROOT / "blender_addon" / "models" / "lipstick_encoder.onnx"
COMPARE_COMMIT = "bb2fc93"  # the last commit whose encoder had seen only procedural lips
PRODUCTS = ("Bare Nude", "Rosy Nude", "Caramel Nude", "Baby Pink Gloss", "Rose Satin", "Hot Pink Matte", "Coral Crush",
            "Classic Red", "Cherry Gloss", "Velvet Red Matte", "Berry Stain", "Burgundy Matte", "Chocolate", "Espresso",
            "Midnight Vinyl", "Goth Black Matte")
SWEEP_PRESETS = ("Bare Nude", "Rose Satin", "Coral Crush", "Classic Red", "Berry Stain", "Chocolate")
SWEEP = (-20.0, -10.0, 0.0, 10.0, 20.0)
SOURCES = range(8)
SLOPE_SOURCES = range(2)
TRYON_SAMPLES = 16


def compare_model(work: Path) -> Path:
    """Today's encoder, written from git (COMPARE_COMMIT) into `work`."""
    path = work / "lipstick_encoder_procedural.onnx"
    shipped = f"{COMPARE_COMMIT}:blender_addon/models/lipstick_encoder.onnx"
    blob = subprocess.run(["git", "-C", str(ROOT), "show", shipped], check=True, capture_output=True).stdout
    path.write_bytes(blob)
    return path


def lab(colour: np.ndarray) -> np.ndarray:
    from vto_core.colour import srgb_to_lab

    return np.asarray(srgb_to_lab(np.asarray(colour, np.float32)), np.float64)


class Renders:
    """Default-scene renders of a product's looks on sources (64 px, 16 spp), kept by look."""

    def __init__(self, renderer: str = "lipstick"):
        self.renderer = renderer
        self.kept: dict[tuple, list] = {}

    def __call__(self, values: dict[str, float], sources) -> list[tuple[np.ndarray, np.ndarray]]:
        from blender_addon.matching.photo_fit import region_renderer

        key = (tuple(sorted((k, round(float(v), 6)) for k, v in values.items())), tuple(sources))
        if key not in self.kept:
            self.kept[key] = [region_renderer(self.renderer, source)(values) for source in sources]
        return self.kept[key]

    def apparent(self, values: dict[str, float], sources) -> np.ndarray:
        """The median over `sources` of the region's mean display colour (3,)."""
        from vto_core.appearance import mean_colour

        return np.median([mean_colour(rgb, mask) for rgb, mask in self(values, sources)], axis=0)


def held_out_faces(count: int) -> list[dict]:
    entries = json.loads((FACES / "faces.json").read_text())
    return [e for e in entries if e["split"] == "held_out"][:count]


ESTIMATES: dict[str, list] = {}  # (model digest, photo, quality) -> [params, ms]; kept in --work between runs
KEPT: list[Path] = []  # where ESTIMATES are kept (--work/estimates.json), written every KEEP_EVERY new estimates
KEEP_EVERY = 10


def estimate(model: Path, path: Path, quality: str) -> tuple[dict[str, float], float]:
    """`vto match`'s estimate of a photo file and its time in ms (kept by the model's content and the photo's name)."""
    from blender_addon.matching.match import match
    from vto_core.dataset import file_digest

    key = f"{file_digest(model)}|{Path(path).name}|{quality}"
    if key not in ESTIMATES:
        started = time.perf_counter()
        result = match(str(model), str(path), quality=quality)
        ESTIMATES[key] = [result["params"], 1000 * (time.perf_counter() - started)]
        if KEPT and len(ESTIMATES) % KEEP_EVERY == 0:  # a long run stopped halfway keeps what it measured
            KEPT[0].write_text(json.dumps(ESTIMATES))
    return ESTIMATES[key][0], ESTIMATES[key][1]


def roundtrip(models: dict[str, Path], qualities: list[str], faces: int, products: int, work: Path,
              renders: Renders, best_faces: int | None = None) -> str:
    """Part (a): rows per model and quality, and per face. best_faces: Best (100 renders a photo) on the first
    best_faces faces only, beside Fast and Better on the same faces."""
    from blender_addon.renderers.tryon import tryon_lipstick
    from vto_core.imageio import read_image, write_image
    from vto_core.presets import load_presets
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    presets = load_presets("lipstick")
    looks = {name: spec.check_values(presets[name]) for name in PRODUCTS[:products]}
    worn = []
    for entry in held_out_faces(faces):
        photo = read_image(ROOT / entry["file"])[0][..., :3]
        for name, values in looks.items():
            path = work / f"{Path(entry['file']).stem}-{name.replace(' ', '_')}.png"
            if not path.exists():
                write_image(path, tryon_lipstick(photo, values, samples=TRYON_SAMPLES))
            worn.append((entry, name, path))
    rows, per_face = [], {}
    subset = best_faces is not None and best_faces < faces and "best" in qualities
    runs = [(label, quality, worn) for label in models for quality in (qualities if label == "new" else ["fast"])
            if not (subset and quality == "best")]
    if subset:
        first = {entry["file"] for entry in held_out_faces(best_faces)}
        some = [look for look in worn if look[0]["file"] in first]
        runs += [("new", quality, some) for quality in qualities]
    for label, quality, looked in runs:
        base = f"{label} encoder, {quality}"
        row_label = base + (f" (first {best_faces} faces)" if looked is not worn else "")
        per_face_too = looked is worn or quality == "best"  # the subset's Fast and Better are in their whole rows
        errors, gains, times = [], [], []
        for entry, name, path in looked:
            values, ms = estimate(models[label], path, quality)
            truth = renders(looks[name], SOURCES)
            guess = renders(values, SOURCES)
            errors.append(delta_e(renders.apparent(looks[name], SOURCES), renders.apparent(values, SOURCES)))
            gains.append(np.mean([psnr(t[0], g[0]) for t, g in zip(truth, guess)]))
            times.append(ms)
            if per_face_too:
                per_face.setdefault(entry["subject"].split(",")[0], {}).setdefault(base, []).append(errors[-1])
        rows.append([row_label, len(looked), f"{np.median(errors):.2f}", f"{np.mean(errors):.2f}",
                     f"{np.mean(gains):.2f}", f"{np.median(times):,.0f}"])
    labels = list(dict.fromkeys(label for by in per_face.values() for label in by))
    face_rows = [[face, *[f"{np.median(by[label]):.2f}" if label in by else "-" for label in labels]]
                 for face, by in per_face.items()]
    return ("\n".join([
        f"{faces} held-out faces x {len(looks)} products ({', '.join(looks)}), tried on with `vto tryon`'s renderer "
        f"({TRYON_SAMPLES} spp) and read back with `vto match`. Truth and estimate rendered on default sources 0-7.",
        "", table(["model, quality", "looks", "median CIEDE2000", "mean CIEDE2000", "PSNR dB on sources 0-7",
                   "median ms"], rows),
        "", "Median CIEDE2000 per face:", "", table(["face", *labels], face_rows)]))


def photo_records(with_packages: bool) -> list[dict]:
    records = json.loads(PHOTOS.read_text())
    records = records["photos"] if isinstance(records, dict) else records
    return [r for r in records if r.get("lips_box") and (with_packages or not r["file"].startswith("package:"))]


def photo_file(record: dict, work: Path) -> Path:
    """The record's photo as a file in `work` (the packaged ones written out)."""
    from benchmarks.bench_real_photos import load_photo
    from vto_core.imageio import write_image

    path = work / f"{Path(record['file']).stem.replace(':', '_').replace('/', '_')}.png"
    if not path.exists():
        write_image(path, load_photo(record, PHOTOS.parent))
    return path


def chroma(values: np.ndarray) -> float:
    return float(np.hypot(values[1], values[2]))


def slopes(models: dict[str, Path], qualities: list[str], work: Path, renders: Renders) -> str:
    """Part (b): lightness and chroma slopes, estimate on photo, over the 16 NASA portraits."""
    from blender_addon.matching.reference import read_reference
    from vto_core.appearance import mean_colour

    records = photo_records(with_packages=False)
    photos = []
    for record in records:
        path = photo_file(record, work)
        reference = read_reference("lipstick", {"image_path": str(path)})
        photos.append((path, lab(mean_colour(*reference.region))))
    rows, per_photo = [], [[r["subject"].split(",")[0], r.get("lipstick_shade", "-"), f"{p[1][0]:.1f}"]
                           for r, p in zip(records, photos)]
    for label, model in models.items():
        for quality in qualities if label == "new" else ["fast"]:
            found = [lab(renders.apparent(estimate(model, path, quality)[0], SLOPE_SOURCES)) for path, _ in photos]
            for row, colour in zip(per_photo, found):
                row.append(f"{colour[0]:.1f}")
            photo_l = [p[1][0] for p in photos]
            photo_c = [chroma(p[1]) for p in photos]
            rows.append([f"{label} encoder, {quality}",
                         f"{min(photo_l):.1f}-{max(photo_l):.1f}", f"{min(f[0] for f in found):.1f}-"
                         f"{max(f[0] for f in found):.1f}", f"{np.polyfit(photo_l, [f[0] for f in found], 1)[0]:.2f}",
                         f"{np.polyfit(photo_c, [chroma(f) for f in found], 1)[0]:.2f}"])
    labels = [row[0] for row in rows]
    return "\n".join([f"{len(photos)} NASA portraits of benchmarks/photos; estimates on default sources 0-1.", "",
                      table(["model, quality", "photos' lips L*", "estimates' L*", "L* slope (goal >= 0.6)",
                             "C* slope (goal >= 0.7)"], rows),
                      "", "L* per portrait:", "", table(["portrait", "lipstick", "photo", *labels], per_photo)])


def lips_moved(image: np.ndarray, mask: np.ndarray, channel: str, amount: float) -> np.ndarray:
    """(H, W, 3) display with L* (channel 'L') or chroma ('C') moved by `amount` inside mask (H, W) > 0.5."""
    from skimage.color import lab2rgb, rgb2lab

    out = np.asarray(image, np.float32).copy()
    inside = mask > 0.5
    pixels = rgb2lab(out[inside][None].astype(np.float64))[0]
    if channel == "L":
        pixels[:, 0] = np.clip(pixels[:, 0] + amount, 0.0, 100.0)
    else:
        c = np.hypot(pixels[:, 1], pixels[:, 2])
        scale = np.maximum(c + amount, 0.0) / np.maximum(c, 1e-6)
        pixels[:, 1:] *= scale[:, None]
    out[inside] = np.clip(lab2rgb(pixels[None])[0], 0.0, 1.0)
    return out


def sweep_slope(reads: list[np.ndarray], channel: str) -> float:
    """The slope of the estimate's L* (C*) on the SWEEP amounts."""
    ys = [r[0] if channel == "L" else chroma(r) for r in reads]
    return float(np.polyfit(SWEEP, ys, 1)[0])


def sweep(models: dict[str, Path], work: Path, renders: Renders) -> str:
    """Part (b2): the lips alone changed, on every portrait and on default renders."""
    from blender_addon.renderers.products import render
    from blender_addon.matching.reference import read_reference
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.imageio import read_image, write_image
    from vto_core.inference import EncoderSession
    from vto_core.presets import load_presets
    from vto_core.products import get_spec

    spec = get_spec("lipstick")
    presets = load_presets("lipstick")
    records = photo_records(with_packages=True)
    rows, summary = [], []
    for label, model in models.items():
        session = EncoderSession(model)
        per_channel = {}
        for channel in ("L", "C"):
            photo_slopes = []
            for record in records:
                path = photo_file(record, work)
                mask = read_reference("lipstick", {"image_path": str(path)}).found.mask
                whole = read_image(path)[0][..., :3]
                reads = []
                for amount in SWEEP:
                    moved = work / f"moved-{path.stem}-{channel}{amount:+.0f}.png"
                    if not moved.exists():
                        write_image(moved, lips_moved(whole, mask, channel, amount))
                    reads.append(lab(renders.apparent(estimate(model, moved, "fast")[0], SLOPE_SOURCES)))
                photo_slopes.append(sweep_slope(reads, channel))
                if channel == "L":
                    rows.append([label, record.get("subject", record["file"]).split(",")[0],
                                 f"{photo_slopes[-1]:.2f}"])
            render_slopes = []
            for name in SWEEP_PRESETS:
                for source in SLOPE_SOURCES:
                    image = render("lipstick", spec.check_values(presets[name]), source, 64)
                    mask = lips_mask(source, 64)
                    reads = [lab(renders.apparent(session.predict(lips_moved(image, mask, channel, a))[0],
                                                  SLOPE_SOURCES)) for a in SWEEP]
                    render_slopes.append(sweep_slope(reads, channel))
            per_channel[channel] = (photo_slopes, render_slopes)
            summary.append([label, "L*" if channel == "L" else "C*", f"{np.median(photo_slopes):.2f}",
                            f"{min(photo_slopes):.2f}", f"{np.median(render_slopes):.2f}",
                            f"{min(render_slopes):.2f}-{max(render_slopes):.2f}",
                            f"{np.median(photo_slopes) - np.median(render_slopes):+.2f}"])
    by_photo = {}
    for label, subject, value in rows:
        by_photo.setdefault(subject, {})[label] = value
    labels = list(models)
    return "\n".join([
        f"Every portrait of benchmarks/photos ({len(records)}), its lips' L* or C* moved by "
        f"{', '.join(f'{a:+.0f}' for a in SWEEP)} inside the lips found, the rest untouched, read by Fast; the "
        f"estimate's L* (C*) on default sources 0-1 against"
        f" the change. Renders: {', '.join(SWEEP_PRESETS)} on default sources 0-1 (64 px), changed likewise inside "
        "their lips mask and read by the encoder.", "",
        table(["model", "channel", "portraits: median slope", "portraits: lowest", "renders: median slope",
               "renders: range", "portraits - renders"], summary),
        "", "L* slope per portrait (goal: >= 0.5 on every one; median within 0.1 of the renders'):", "",
        table(["portrait", *labels], [[s, *[by.get(k, "-") for k in labels]] for s, by in by_photo.items()])])


PULLS = (0.0, 0.1, 0.2, 0.4, 0.6, 1.0)  # part (e): shares of the way from the estimate's L* to the photo lips'


def exposure(model: Path, work: Path) -> str:
    """Part (e): skin against lips across faces and under an exposure; the pulled estimates' slope and re-lit
    spread."""
    from benchmarks.bench_light import PHOTO_SHIFTS, relit_files
    from blender_addon.matching.photo_fit import apparent_colour
    from blender_addon.matching.reference import read_reference
    from vto_core.appearance import mean_colour
    from vto_core.colour import ciede2000

    portraits = []  # (NASA?, light -> (photo lips Lab, skin L*, estimate's apparent Lab))
    for record in photo_records(with_packages=True):
        read = {}
        for name, path in relit_files(record, work).items():
            image, mask = read_reference("lipstick", {"image_path": str(path)}).region
            found = apparent_colour("lipstick", estimate(model, path, "fast")[0], sources=SOURCES)["mean"]
            read[name] = (lab(mean_colour(image, mask)), lab(mean_colour(image, (mask < 0.5).astype(np.float32)))[0],
                          lab(found))
        portraits.append((not record["file"].startswith("package:"), read))
    nasa = [read["as it is"] for is_nasa, read in portraits if is_nasa]
    lips_l, skin_l = np.array([r[0][0] for r in nasa]), np.array([r[1] for r in nasa])
    exposures = [name for name in PHOTO_SHIFTS if "EV" in name]
    lips_moves = [read[name][0][0] - read["as it is"][0][0] for _, read in portraits for name in exposures]
    skin_moves = [read[name][1] - read["as it is"][1] for _, read in portraits for name in exposures]
    exposed = np.divide(skin_moves, lips_moves)

    def pulled(reading, k):
        found = reading[2].copy()
        found[0] += k * (reading[0][0] - found[0])
        return found

    rows = []
    for k in PULLS:
        slope = np.polyfit(lips_l, [pulled(r, k)[0] for r in nasa], 1)[0]
        spread = {name: [float(ciede2000(pulled(read["as it is"], k), pulled(read[name], k))) for _, read in portraits]
                  for name in PHOTO_SHIFTS}
        by_cast = [e for name, errors in spread.items() if name not in exposures for e in errors]
        by_exposure = [e for name in exposures for e in spread[name]]
        rows.append([f"{k:.1f}", f"{slope:.2f}", f"{np.median(by_cast + by_exposure):.2f}",
                     f"{np.median(by_cast):.2f}", f"{np.median(by_exposure):.2f}"])
    return "\n".join([
        f"{len(portraits)} portraits of benchmarks/photos re-lit ({', '.join(PHOTO_SHIFTS)}); the new model's Fast, "
        f"apparent colour on default sources 0-7; the lips and the skin beside them (the rest of the lips frame) as "
        f"Match reads them, the light taken out.", "",
        f"- Across the {len(nasa)} NASA portraits the skin's L* moves {np.polyfit(lips_l, skin_l, 1)[0]:.2f} per unit "
        f"of the lips' (correlation {np.corrcoef(lips_l, skin_l)[0, 1]:.2f}); under +-0.7 EV it moves "
        f"{np.median(exposed):.2f} (median; {min(exposed):.2f}-{max(exposed):.2f}). Darker lips come with darker skin "
        f"as an exposure darkens both: what is read from the lips and the skin cannot tell a darker face from a "
        f"darker exposure.",
        f"- The lips' L* moves a median {np.median(np.abs(lips_moves)):.1f} under +-0.7 EV.", "",
        "An estimate whose L* is moved a share k of the way to the photo lips' L* (k = 0: Fast as it is; 1: the "
        "photo's lightness copied):", "",
        table(["k", "L* slope, 16 NASA portraits (goal >= 0.6)", "re-lit median (goal <= 2)", "white balances median",
               "+-0.7 EV median"], rows)])


def picture(models: dict[str, Path], qualities: list[str], faces: int, out: Path) -> str:
    """Part (d): per held-out face, its photo around the lips | each model's Fast (and the new one's other
    `qualities`) tried on it | each estimate on the default lips (source 0)."""
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.renderers.tryon import tryon_view
    from vto_core.imageio import read_image, write_image
    from vto_core.products import LIPSTICK

    size, rows = 128, []
    for entry in held_out_faces(faces):
        path = ROOT / entry["file"]
        photo = read_image(path)[0][..., :3]
        estimates = {f"{label} Fast": estimate(model, path, "fast")[0] for label, model in models.items()}
        estimates.update({f"new {quality.title()}": estimate(models["new"], path, quality)[0]
                          for quality in qualities if quality != "fast"})
        cells = [tryon_view(photo, next(iter(estimates.values())), size, TRYON_SAMPLES, 0, LIPSTICK)[0]]
        cells += [tryon_view(photo, values, size, TRYON_SAMPLES, 0, LIPSTICK)[1] for values in estimates.values()]
        cells += [render_lipstick(values, 0, size, TRYON_SAMPLES, 0) for values in estimates.values()]
        rows.append(np.concatenate(cells, axis=1))
    write_image(out, np.concatenate(rows, axis=0))
    labels = list(estimates)
    return (f"![held-out faces]({out.name})\n\n*Each held-out face (its own lips, some wearing a lipstick of their "
            f"own): the photo | {' | '.join(f'{label} tried on it' for label in labels)} | "
            f"{' | '.join(f'{label} on the default lips' for label in labels)}.*")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=str(MODEL))
    parser.add_argument("--compare", default=None, help=f"today's encoder (default: the one of {COMPARE_COMMIT})")
    parser.add_argument("--parts", default="roundtrip,slopes,sweep,picture,exposure")
    parser.add_argument("--qualities", default="fast")
    parser.add_argument("--faces", type=int, default=13)
    parser.add_argument("--products", type=int, default=len(PRODUCTS))
    parser.add_argument("--best-faces", type=int, default=None,
                        help="the round trip's Best on the first N faces only (it takes 6x Better's renders)")
    parser.add_argument("--work", default=None, help="a folder kept between runs (try-ons, moved photos)")
    parser.add_argument("--results", default=str(RESULTS))
    args = parser.parse_args(argv)
    work = Path(args.work or tempfile.mkdtemp(prefix="vto-photo-sources-"))
    work.mkdir(parents=True, exist_ok=True)
    models = {"today's": Path(args.compare) if args.compare else compare_model(work), "new": Path(args.model)}
    qualities = args.qualities.split(",")
    renders = Renders()
    kept = work / "estimates.json"
    ESTIMATES.update(json.loads(kept.read_text()) if kept.exists() else {})
    KEPT[:] = [kept]
    parts = args.parts.split(",")
    command = (f"python -m benchmarks.bench_photo_sources --parts {args.parts} --qualities {args.qualities} "
               f"--faces {args.faces} --products {args.products}"
               + (f" --best-faces {args.best_faces}" if args.best_faces else ""))
    shown = Path(args.model).resolve()
    shown = shown.relative_to(ROOT) if shown.is_relative_to(ROOT) else shown
    heading = f"Reproduce: `{command}`. New: `{shown}`.\n\n"
    if "roundtrip" in parts:
        write_section("photo_sources", "roundtrip", heading + roundtrip(models, qualities, args.faces, args.products,
                                                                        work, renders, args.best_faces),
                      Path(args.results))
        kept.write_text(json.dumps(ESTIMATES))
    if "slopes" in parts:
        write_section("photo_sources", "slopes", heading + slopes(models, qualities, work, renders), Path(args.results))
        kept.write_text(json.dumps(ESTIMATES))
    if "sweep" in parts:
        write_section("photo_sources", "sweep", heading + sweep(models, work, renders), Path(args.results))
        kept.write_text(json.dumps(ESTIMATES))
    if "picture" in parts:
        write_section("photo_sources", "picture", heading + picture(models, qualities, args.faces,
                                                                     Path(args.results) / "photo_sources.png"),
                      Path(args.results))
    if "exposure" in parts:
        write_section("photo_sources", "exposure", heading + exposure(models["new"], work), Path(args.results))
    kept.write_text(json.dumps(ESTIMATES))
    print(f"wrote {Path(args.results) / 'photo_sources.md'}")


if __name__ == "__main__":
    main()
