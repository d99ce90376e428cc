"""Photos as phones give them: the same portrait in every EXIF orientation, tilted, upside down, in black and white.

    python -m benchmarks.bench_photo_forms [--limit N]

For each portrait of benchmarks/photos with a face: the upright photo is saved as a TIFF (lossless, Orientation 1);
then (a) stored in each of the eight EXIF orientations, its pixels laid so that a viewer shows it upright; (b) turned
-45 to 45 degrees in steps of 15, and 180, its canvas grown to hold it (black corners). Each goes through `vto match`
(Fast) for lips and for hair (the hair found in the whole portrait). TIFFs are lossless, so every orientation
stores the same pixels. Figure: the CIEDE2000 between the apparent colour
(on default sources 0-1, blender_addon.matching.photo_fit.apparent_colour) of the estimate and that of the upright
photo's estimate. (c) Monochrome: colour_spread and grey chroma (vto_core.photo.monochrome) of each photo, of it
desaturated to 40 %, and of its black-and-white, sepia and cyanotype JPEGs, with the margins to the thresholds.
(d) Times on each portrait at about a megapixel, each way timed in turn: reading the file (orientation applied, or
not), the face read as before (one refine pass, no turn-over check) and as now, and the monochrome check.
Writes benchmarks/results/photo_forms.md.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import MODELS, PHOTOS, delta_e, load_photo
from benchmarks.common import machine, table, tilted

TILTS = (-45, -30, -15, 15, 30, 45, 180)
# Orientation tag -> how the stored pixels are laid so that a viewer applying the tag shows the upright photo.
STORED = {1: lambda a: a, 2: lambda a: a[:, ::-1], 3: lambda a: a[::-1, ::-1], 4: lambda a: a[::-1],
          5: lambda a: a.swapaxes(0, 1), 6: lambda a: np.rot90(a, 1), 7: lambda a: a[::-1, ::-1].swapaxes(0, 1),
          8: lambda a: np.rot90(a, -1)}
RESULT = Path(__file__).parent / "results" / "photo_forms.md"
SOURCES = (0, 1)  # the default sources an estimate's apparent colour is read on, as the issue measured it


class Apparent:
    """Apparent colours of estimates, rendered once per distinct estimate."""

    def __init__(self, renderer: str):
        self.renderer, self.cache = renderer, {}

    def __call__(self, values: dict[str, float]) -> np.ndarray:
        from blender_addon.matching.photo_fit import apparent_colour

        key = tuple(round(float(values[k]), 5) for k in sorted(values))
        if key not in self.cache:
            self.cache[key] = apparent_colour(self.renderer, values, sources=SOURCES)["mean"]
        return self.cache[key]


def forms(records: list[dict], work: Path) -> tuple[list, dict]:
    """Per portrait and renderer, CIEDE2000 of each form's estimate to the upright one: (rows, form -> errors)."""
    from blender_addon.matching.match import match
    from vto_core.imageio import write_image

    rows, pooled = [], {}
    for record in records:
        photo = load_photo(record, PHOTOS.parent)
        stem = Path(record["file"]).stem.replace(":", "_").replace("/", "_")
        paths = {"upright": write_image(work / f"{stem}_o1.tif", photo)}
        for orientation in range(2, 9):
            paths[f"EXIF {orientation}"] = write_image(work / f"{stem}_o{orientation}.tif",
                                                       STORED[orientation](photo), orientation=orientation)
        for degrees in TILTS:
            paths[f"tilt {degrees:+d}"] = write_image(work / f"{stem}_t{degrees}.png", tilted(photo, degrees))
        for renderer in ("lipstick", "hair"):
            apparent, model = Apparent(renderer), str(MODELS / f"{renderer}_encoder.onnx")
            try:
                upright = apparent(match(model, str(paths["upright"]))["params"])
            except Exception as exc:  # a portrait whose hair is refused upright: nothing to compare against
                rows.append([record["subject"], renderer, f"upright refused: {str(exc)[:60]}"] + [""] * 2)
                continue
            errors = {}
            for form, path in paths.items():
                if form == "upright":
                    continue
                try:
                    errors[form] = delta_e(upright, apparent(match(model, str(path))["params"]))
                except Exception:  # refused in this form while upright was read: counted as a failure
                    errors[form] = math.inf
                pooled.setdefault((renderer, form.split(" ")[0]), []).append(errors[form])
            exif = [errors[f"EXIF {o}"] for o in range(2, 9)]
            tilts = [errors[f"tilt {d:+d}"] for d in TILTS]
            rows.append([record["subject"], renderer, f"{max(exif):.2f}", f"{np.median(tilts):.2f}",
                         f"{max(tilts):.2f}"])
        print(f"{record['subject']} done", file=sys.stderr, flush=True)
    return rows, pooled


def monochrome_rows(records: list[dict], work: Path) -> tuple[list, dict]:
    """Per portrait: grey chroma / colour spread of it and its monochrome prints."""
    from vto_core.imageio import read_image, write_image
    from vto_core.photo.monochrome import colour_spread, grey_chroma, lab_of

    def grey(image):
        return np.repeat((image @ np.array([0.2126, 0.7152, 0.0722], np.float32))[..., None], 3, axis=2)

    prints = {
        "colour": lambda image: image,
        "desaturated to 40 %": lambda image: grey(image) + 0.4 * (image - grey(image)),
        "black and white (JPEG)": grey,
        "sepia (JPEG)": lambda image: np.clip(grey(image) * np.array([1.07, 0.94, 0.74], np.float32), 0, 1),
        "cyanotype (JPEG)": lambda image: np.clip(np.array([0.0, 0.12, 0.30], np.float32) + grey(image)
                                                  * np.array([0.85, 0.83, 0.70], np.float32), 0, 1),
    }
    rows, pooled = [], {}
    for record in records:
        photo = load_photo(record, PHOTOS.parent)
        cells = [record["subject"]]
        for name, make in prints.items():
            image = make(photo)
            if "JPEG" in name:
                image = read_image(write_image(work / "print.jpg", image))[0]
            lab = lab_of(image)
            measures = (grey_chroma(lab), colour_spread(lab))
            pooled.setdefault(name, []).append(measures)
            cells.append(f"{measures[0]:.1f} / {measures[1]:.2f}")
        rows.append(cells)
    return rows, pooled


def paired_ms(before, now, repeats: int = 15) -> tuple[float, float, float]:
    """ms of two callables timed in turn (before, now, before, ...), so that a busy machine slows both alike: (median
    before, median now, median of the paired differences now - before)."""
    before(), now()
    spans = []
    for _ in range(repeats):
        pair = []
        for fn in (before, now):
            started = time.perf_counter()
            fn()
            pair.append(1000 * (time.perf_counter() - started))
        spans.append(pair)
    spans = np.array(spans)
    return float(np.median(spans[:, 0])), float(np.median(spans[:, 1])), float(np.median(spans[:, 1] - spans[:, 0]))


class AsBefore:
    """The face reader as it read before roll and turn-over (one refine pass, no turn-over check), inside a with."""

    SETTINGS = {"REFINE_PASSES": 1, "SURE_FACE_LOGIT": -math.inf}

    def __enter__(self):
        from vto_core.photo import face_reader

        self.kept = {name: getattr(face_reader, name) for name in self.SETTINGS}
        for name, value in self.SETTINGS.items():
            setattr(face_reader, name, value)

    def __exit__(self, *exc):
        from vto_core.photo import face_reader

        for name, value in self.kept.items():
            setattr(face_reader, name, value)


def megapixel(record: dict) -> np.ndarray:
    """A record's photo resized to about a megapixel, clipped to [0, 1] as Match reads a file."""
    from vto_core.imageio import resize

    photo = load_photo(record, PHOTOS.parent)
    scale = math.sqrt(1.0e6 / (photo.shape[0] * photo.shape[1]))
    return np.clip(resize(photo, round(photo.shape[0] * scale), round(photo.shape[1] * scale)), 0.0, 1.0)


def times(records: list[dict], work: Path) -> tuple[list[list], list[list]]:
    """What orientation and roll add, on each portrait resized to about a megapixel, timed in turn (paired_ms):
    (rows for the first portrait, rows per portrait: mesh passes and ms of the face read as before and now)."""
    from vto_core.imageio import read_image, write_image
    from vto_core.photo import face_reader
    from vto_core.photo.monochrome import monochrome_problem

    reader = face_reader.FaceReader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx")
    passes = []
    counted = reader.mesh_read

    def mesh_read(*args, **kwargs):
        passes.append(1)
        return counted(*args, **kwargs)

    reader.mesh_read = mesh_read

    def read_as_before(image):
        with AsBefore():
            return reader.read(image)

    photo = megapixel(records[0])
    path = write_image(work / "megapixel.tif", photo)
    stored, shown, added = paired_ms(lambda: read_image(path, as_shown=False), lambda: read_image(path))
    first = [["read the file: as stored / turned as shown (Orientation 1)", f"{stored:.1f} / {shown:.1f}",
              f"{added:+.1f}"]]
    turned = tilted(photo, 30)
    old, new, added = paired_ms(lambda: read_as_before(turned), lambda: reader.read(turned), 5)
    first.append(["face read, tilted 30 degrees: as before / now", f"{old:.1f} / {new:.1f}", f"{added:+.1f}"])
    check = paired_ms(lambda: None, lambda: monochrome_problem(photo, "lipstick"))[1]
    first.append(["monochrome check", f"{check:.1f}", ""])
    per_portrait = []
    for record in records:
        image = megapixel(record)
        counts = []
        for read in (read_as_before, reader.read):
            passes.clear()
            read(image)
            counts.append(len(passes))
        old, new, added = paired_ms(lambda: read_as_before(image), lambda: reader.read(image))
        per_portrait.append([record["subject"], f"{counts[0]} / {counts[1]}", f"{old:.1f} / {new:.1f}",
                             f"{added:+.1f}"])
    return first, per_portrait


def summarise(pooled: dict) -> list[list]:
    """(renderer, kind) -> [renderer, kind, n, median, largest, refused]."""
    out = []
    for (renderer, kind), errors in sorted(pooled.items()):
        finite = [e for e in errors if math.isfinite(e)]
        out.append([renderer, "eight EXIF orientations" if kind == "EXIF" else "tilts -45..45 and 180", len(errors),
                    f"{np.median(finite):.2f}" if finite else "-", f"{max(finite):.2f}" if finite else "-",
                    len(errors) - len(finite)])
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, default=0, help="only the first N portraits (0: all)")
    args = parser.parse_args(argv)
    records = [r for r in json.loads(PHOTOS.read_text()) if r.get("faces")]
    records = records[:args.limit] if args.limit else records
    command = "python -m benchmarks.bench_photo_forms" + (f" {shlex.join(argv)}" if argv else "")
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        timing, timing_faces = times(records, work)
        mono_rows, mono = monochrome_rows(records, work)
        rows, pooled = forms(records, work)
    colour_low = min(m[1] for name in ("colour",) for m in mono[name])
    desaturated_low = min(m[1] for m in mono["desaturated to 40 %"])
    toned_high = max(m[1] for name in ("sepia (JPEG)", "cyanotype (JPEG)") for m in mono[name])
    grey_high = max(m[0] for m in mono["black and white (JPEG)"])
    from vto_core.photo.monochrome import GREY_CHROMA, MIN_SPREAD

    added_ms = [float(row[-1]) for row in timing_faces]

    text = (f"# Photos as phones give them\n\nMachine: {machine()}. Reproduce: `{command}`.\n\n"
            "## Orientation and tilt\n\nCIEDE2000 of each form's Fast estimate (apparent colour on default sources "
            "0-1) to the upright photo's, pooled over the portraits; 'refused' counts forms read as no face or no "
            "hair where the upright photo was read.\n\n"
            + table(["renderer", "forms", "n", "median", "largest", "refused"], summarise(pooled))
            + "\n\nPer portrait (largest over the seven other EXIF orientations; median and largest over the tilts):"
            "\n\n" + table(["portrait", "renderer", "EXIF, largest", "tilt, median", "tilt, largest"], rows)
            + "\n\n## No colour, no answer\n\nGrey chroma (99th percentile, CIELAB) / colour spread (RMS chroma "
            "not explained by lightness, vto_core.photo.monochrome) of each portrait and its prints. A photo is "
            f"refused as black and white under grey chroma {GREY_CHROMA}, as a toned print under colour spread "
            f"{MIN_SPREAD}.\n\n"
            + table(["portrait"] + list(mono), mono_rows)
            + f"\n\nMargins: the lowest colour portrait spreads {colour_low:.2f} ({colour_low / MIN_SPREAD:.1f}x the "
            f"threshold), the lowest desaturated one {desaturated_low:.2f} ({desaturated_low / MIN_SPREAD:.1f}x); the "
            f"highest toned print {toned_high:.2f} ({MIN_SPREAD / max(toned_high, 1e-9):.1f}x under it); the highest "
            f"black-and-white grey chroma {grey_high:.2f} (threshold {GREY_CHROMA}).\n\n"
            "## Times\n\nWhat orientation and roll add to Match: ms on each portrait resized to about a megapixel, "
            "median of 15 runs of each way timed in turn (before, now, before, ...), and the median of the paired "
            "differences. 'As before' is the face read with one refine pass and no turn-over check; an upright face "
            "reads as before, and only one rolled past 5 degrees is read again until its roll settles.\n\n"
            + table(["step (first portrait)", "ms", "added"], timing) + "\n\n"
            + table(["portrait", "mesh passes, before / now", "face read ms, before / now", "added"], timing_faces)
            + f"\n\nAdded by the face read: median {np.median(added_ms):+.1f} ms over the portraits, largest "
            f"{max(added_ms):+.1f}.\n")
    RESULT.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
