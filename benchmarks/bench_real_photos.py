"""The shipped encoders on real, public-domain photos: lips found in whole portraits, hair from patches; Fast, Better
and Best, each estimate rendered on the default scene and its colour compared with the photo's.

    python -m benchmarks.bench_real_photos [--photos benchmarks/photos/photos.json] [--qualities fast,better,best]

Photos: benchmarks/photos/photos.json (each with its source, licence, a hand-drawn lips box and hair patches), the
two that ship in packages among them. Each goes in whole, as an artist gives it, through `vto match`'s own path
(blender_addon.matching.match.match).

Lips. The photo's lip colour is read over the lips the locator found (their mean, and their per-channel median: the
body colour without highlights); the estimate's apparent colour is the same statistic over the lips of its renders
on default sources 0-7 (64 px, 16 spp), the median over the sources (blender_addon.matching.photo_fit.apparent_colour).
The figure is CIEDE2000 between the two. Found: the IoU of the found lips' box with the hand-drawn one.
Hair. The patch (hair only) goes in as a crop; the photo's colour is the patch's mean (and median); the estimate's
is read likewise over the hair of its renders on default hair regions 0-7.
The Better and Best fits render on default sources of their own (900001 and up), never 0-7.
This colour can be won by copying the photo's light into the product, and means something only for photos in neutral
light (these are studio portraits); the first figures of real_photos.md are the ones that cannot: how far each
estimate moves when the same photo is re-lit (benchmarks/bench_light.py, its photos and hair parts). The encoder
alone, with the photo's light left in, is reported beside the qualities.
Photos marked held_out in photos.json were added after the methods and their settings were fixed: the summary gives
them apart. Also: inputs with no lips (noise, a blank image, a landscape) must be refused in one line, and a photo
with several faces must use the largest. Writes benchmarks/results/real_photos.md (a section each for lips and hair;
--only lips|hair redoes one) and real_photos_lips.png, real_photos_hair.png.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, box_iou, table, write_section

PHOTOS = Path(__file__).parent / "photos" / "photos.json"
MODELS = Path(__file__).resolve().parent.parent / "blender_addon" / "models"
QUALITIES = ("fast", "better", "best")
ENCODER = "encoder, light left in"
SHOW = 128  # px of each picture cell


def load_photo(record: dict, folder: Path) -> np.ndarray:
    """A record's photo (H, W, 3) in [0, 1]: a file beside photos.json, or 'package:...' (scikit-image, matplotlib)."""
    from vto_core.imageio import read_image

    name = record["file"]
    if name == "package:skimage.data.astronaut":
        import skimage.data

        return skimage.data.astronaut().astype(np.float32) / 255
    if name == "package:matplotlib/grace_hopper.jpg":
        from matplotlib import cbook

        return read_image(cbook.get_sample_data("grace_hopper.jpg", asfileobj=False))[0]
    return read_image(folder / name)[0][..., :3]


def delta_e(a: np.ndarray, b: np.ndarray) -> float:
    """CIEDE2000 between two display colours (3,)."""
    from vto_core.colour import ciede2000, srgb_to_lab

    return float(ciede2000(srgb_to_lab(a), srgb_to_lab(b)))


def timed_match(model: Path, path: Path, quality: str, crop=None) -> tuple[dict, float]:
    """blender_addon.matching.match.match on a file, and its wall time in ms (the model's session made beforehand).
    Quality ENCODER: the encoder alone on the photo as it is, its light left in (what Fast was before the light was
    read)."""
    from blender_addon.matching.match import match

    started = time.perf_counter()
    if quality == ENCODER:
        result = match(str(model), str(path), crop=crop, neutral_light=False)
    else:
        result = match(str(model), str(path), quality=quality, crop=crop)
    return result, 1000 * (time.perf_counter() - started)


def show(image: np.ndarray, size: int = SHOW) -> np.ndarray:
    """(H, W, 3) fitted into a (size, size, 3) cell on grey, aspect kept."""
    from vto_core.imageio import resize

    height, width = image.shape[:2]
    scale = size / max(height, width)
    h, w = max(1, round(height * scale)), max(1, round(width * scale))
    cell = np.full((size, size, 3), 0.16, np.float32)
    top, left = (size - h) // 2, (size - w) // 2
    cell[top:top + h, left:left + w] = np.clip(resize(image, h, w), 0, 1)
    return cell


def lips_cell(reference) -> np.ndarray:
    """What the encoder read (the framed lips), with the lips found outlined."""
    from blender_addon.ui.thumbnail import outline

    cell = show(reference.image)
    if reference.found is not None and len(reference.found.outer):
        x, y, w, h = reference.box
        scale = SHOW / max(w, h)
        canvas = np.concatenate([cell, np.ones((SHOW, SHOW, 1), np.float32)], -1)
        for contour in (reference.found.outer, reference.found.inner):
            outline(canvas, (np.asarray(contour, np.float64) - (x, y)) * scale, (0.2, 0.9, 1.0))
        cell = canvas[..., :3]
    return cell


def run_lips(records: list[dict], folder: Path, qualities: list[str], work: Path) -> tuple[list, list, list]:
    """Rows of the lips table, the speed rows (quality, ms, delta E) and the picture rows."""
    from blender_addon.renderers.products import render
    from blender_addon.matching.photo_fit import apparent_colour
    from blender_addon.matching.reference import read_reference
    from vto_core.appearance import body_colour, mean_colour
    from vto_core.imageio import write_image

    model = MODELS / "lipstick_encoder.onnx"
    rows, speed, pictures = [], [], []
    for record in records:
        if not record.get("lips_box"):
            continue
        photo = load_photo(record, folder)
        path = work / f"{Path(record['file']).stem.replace(':', '_').replace('/', '_')}.png"
        write_image(path, photo)
        reference = read_reference("lipstick", {"image_path": str(path), "neutral_light": False})  # the photo's colours
        iou = box_iou(reference.found.box, record["lips_box"]) if reference.found is not None else 0.0
        photo_mean, photo_body = mean_colour(*reference.region), body_colour(*reference.region)
        cells = [show(photo), lips_cell(reference)]
        for quality in [ENCODER, *qualities]:
            result, ms = timed_match(model, path, quality)
            values = result["params"]
            apparent = apparent_colour("lipstick", values)
            apparent_mean, apparent_body = apparent["mean"], apparent["body"]
            e_mean, e_body = delta_e(photo_mean, apparent_mean), delta_e(photo_body, apparent_body)
            rows.append([subject(record), record.get("lipstick_shade", "-"), f"{iou:.2f}", quality,
                         _rgb(photo_mean), _rgb(apparent_mean), f"{e_mean:.1f}", f"{e_body:.1f}", f"{ms:,.0f}",
                         _values(values, ("opacity", "red", "green", "blue", "gloss", "reflection"))])
            speed.append((quality, ms, e_mean, bool(record.get("held_out"))))
            cells.append(render("lipstick", values, 1, SHOW, 32))
        pictures.append(np.concatenate(cells, axis=1))
    return rows, speed, pictures


def run_hair(records: list[dict], folder: Path, qualities: list[str], work: Path) -> tuple[list, list, list]:
    """Rows of the hair table, the speed rows and the picture rows (patch | each quality on default regions 0, 1)."""
    from blender_addon.matching.photo_fit import apparent_colour, region_renderer
    from vto_core.appearance import body_colour
    from vto_core.colour import srgb_to_lab
    from vto_core.imageio import write_image

    model = MODELS / "hair_encoder.onnx"
    rows, speed, pictures = [], [], []
    for record in records:
        for patch_index, patch in enumerate(record.get("hair_patches", [])[:1]):
            photo = load_photo(record, folder)
            path = work / f"{Path(record['file']).stem.replace(':', '_').replace('/', '_')}.png"
            write_image(path, photo)
            x, y, w, h = patch
            pixels = photo[y:y + h, x:x + w]
            ones = np.ones(pixels.shape[:2])
            photo_mean, photo_body = pixels.reshape(-1, 3).mean(0), body_colour(pixels, ones)
            cells = [show(pixels)]
            for quality in qualities:
                result, ms = timed_match(model, path, quality, crop=tuple(patch))
                values = result["params"]
                apparent = apparent_colour("hair", values)
                apparent_mean, apparent_body = apparent["mean"], apparent["body"]
                e_mean, e_body = delta_e(photo_mean, apparent_mean), delta_e(photo_body, apparent_body)
                lightness = float(srgb_to_lab(apparent_mean)[0] - srgb_to_lab(photo_mean)[0])
                rows.append([subject(record), record.get("hair", "-"), quality, _rgb(photo_mean),
                             _rgb(apparent_mean), f"{e_mean:.1f}", f"{e_body:.1f}", f"{lightness:+.1f}",
                             f"{ms:,.0f}"])
                speed.append((quality, ms, e_mean, bool(record.get("held_out"))))
                cells += [region_renderer("hair", source)(values)[0] for source in (0, 1)]
            pictures.append(np.concatenate([show(c) for c in cells], axis=1))
    return rows, speed, pictures


def refusals(records: list[dict], folder: Path, work: Path) -> list[list]:
    """Inputs with no lips (noise, blank images, the photos without a face): what `vto match` says (one line, exit
    status 2, nothing written)."""
    import subprocess

    from vto_core.imageio import write_image

    rng = np.random.default_rng(0)
    inputs = {"uniform noise": rng.random((480, 640, 3)), "blank white": np.ones((480, 640, 3)),
              "blank black": np.zeros((480, 640, 3))}
    inputs.update({record["subject"]: load_photo(record, folder) for record in records if record.get("faces") == 0})
    rows = []
    for name, image in inputs.items():
        path = work / f"refuse_{len(rows)}.png"
        write_image(path, image)
        out = work / f"refuse_{len(rows)}.json"
        done = subprocess.run([sys.executable, "-m", "vto_core.cli", "match", "--model",
                               str(MODELS / "lipstick_encoder.onnx"), "--image", str(path), "--out-params", str(out)],
                              capture_output=True, text=True)
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        rows.append([name, done.returncode, f"`{lines[-1] if lines else ''}`", "no" if not out.exists() else "YES"])
    return rows


def subject(record: dict) -> str:
    """The record's subject, marked where the photo is held out (added after the methods were fixed)."""
    return record["subject"] + (" **(held out)**" if record.get("held_out") else "")


def summary_rows(speed: list[tuple[str, float, float, bool]], qualities: list[str]) -> list[list]:
    """Per set of photos (all; those seen while the methods were built; the held-out ones) and quality: the number of
    photos, median ms and median / max CIEDE2000."""
    rows = []
    for name, keep in (("all", lambda held: True), ("seen while building", lambda held: not held),
                       ("held out", lambda held: held)):
        for quality in qualities:
            picked = [(ms, e) for q, ms, e, held in speed if q == quality and keep(held)]
            if picked and (name == "all" or len(picked) < len([1 for q, *_ in speed if q == quality])):
                ms, errors = np.array(picked).T
                rows.append([name, len(picked), quality, f"{np.median(ms):,.0f}", f"{np.median(errors):.1f}",
                             f"{errors.max():.1f}"])
    return rows


def _rgb(colour: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.0f}" for v in 255 * np.asarray(colour)) + ")"


def _values(values: dict, names: tuple[str, ...]) -> str:
    return ", ".join(f"{values[n]:.2f}" if values[n] < 10 else f"{values[n]:.0f}" for n in names)


def main(argv: list[str] | None = None) -> None:
    """Run the lips and hair parts and write the report."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--photos", default=str(PHOTOS))
    parser.add_argument("--qualities", default=",".join(QUALITIES))
    parser.add_argument("--only", default="", help="lips or hair (default both)")
    args = parser.parse_args(argv)
    from vto_core.imageio import write_image

    qualities = [q for q in args.qualities.split(",") if q]
    folder = Path(args.photos).parent
    records = json.loads(Path(args.photos).read_text())
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        lips = run_lips(records, folder, qualities, work) if args.only in ("", "lips") else ([], [], [])
        hair = run_hair(records, folder, qualities, work) if args.only in ("", "hair") else ([], [], [])
        refused = refusals(records, folder, work) if args.only in ("", "lips") else []
    if lips[2]:
        write_image(RESULTS / "real_photos_lips.png", np.concatenate(lips[2], axis=0))
    if hair[2]:
        write_image(RESULTS / "real_photos_hair.png", np.concatenate(hair[2], axis=0))
    command = "python -m benchmarks.bench_real_photos " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
    reproduce = (f"Reproduce: `{command.strip()}`. Every photo is public domain; its source and licence are in "
                 "benchmarks/photos/photos.json.")
    if lips[0]:
        text = ["## Lips, whole portraits in", "",
                "CIEDE2000 between the photo's lips (found by the locator) and the estimate's lips on default "
                "sources 0-7 (median over the sources): the mean colour, and the body colour (per-channel median). "
                "Found: IoU of the found lips' box with the hand-drawn box.", "",
                table(["photo", "lipstick", "found (IoU)", "quality", "photo lips", "estimate's lips", "ΔE mean",
                       "ΔE body", "ms", "opacity, R, G, B, gloss, reflection"], lips[0]), "",
                "Speed against accuracy on these photos:", "",
                table(["photos", "n", "quality", "median ms", "median ΔE (mean colour)", "largest ΔE"],
                      summary_rows(lips[1], [ENCODER, *qualities])), "",
                "real_photos_lips.png, per row: the photo | the lips found (what the encoder reads, the contours "
                "outlined) | " + " | ".join([ENCODER, *qualities]) + " rendered on default source 1.", ""]
        if refused:
            text += ["Inputs without lips (`vto match --model lipstick_encoder.onnx --image X --out-params P`):", "",
                     table(["input", "exit status", "what it says", "file written"], refused), ""]
        write_section("real_photos", "real-photos-lips", "\n".join(text + [reproduce]))
    if hair[0]:
        text = ["## Hair, patches in", "",
                "CIEDE2000 between the patch and the estimate's hair on default hair regions 0-7 (median over the "
                "regions), mean and body colour; ΔL*: the estimate's lightness minus the photo's.", "",
                table(["photo", "hair", "quality", "photo hair", "estimate's hair", "ΔE mean", "ΔE body", "ΔL*",
                       "ms"], hair[0]), "",
                "Speed against accuracy on these patches:", "",
                table(["photos", "n", "quality", "median ms", "median ΔE (mean colour)", "largest ΔE"],
                      summary_rows(hair[1], qualities)), "",
                "real_photos_hair.png, per row: the patch | for each quality, the estimate on default hair regions "
                "0 and 1.", ""]
        write_section("real_photos", "real-photos-hair", "\n".join(text + [reproduce]))


if __name__ == "__main__":
    main()
