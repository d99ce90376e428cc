"""Hair found in whole portraits and in tight crops of them: the hair locator against hand-drawn masks, and Fast,
Better and Best from the photo (no crop, no mask) against the colour of the hand-drawn hair.

    python -m benchmarks.bench_hair_found [--qualities fast,better,best] [--only FILE ...] [--sets whole,crops]

Photos: benchmarks/photos/photos.json, the 18 with hair; hand-drawn hair masks: benchmarks/photos/hair_masks.json
(benchmarks/hand_masks.py). Per photo: the IoU of the hair found with the hand mask; the CIEDE2000 between the mean
colour of the hair found and of the hand patch (photos.json's first hair patch, as bench_real_photos reads it); the
time to find the hair (the person model and the colour models; the face mesh apart); each quality through `vto
match`'s own path on the whole photo, its estimate rendered on default hair regions 0-7 and its apparent colour
against the hand patch's. Photos marked held_out are summarised apart. Also the refusals: pictures with no hair.
Tight crops: each portrait cut as beauty and makeup photos are framed, from the eyebrows to the chin (the face
detector's box on the whole portrait, top to bottom) and 1.6 face widths (the box's width) across, its hand mask cut
alike; the same figures, against the mean colour of the hand-drawn hair inside the crop. A crop shows hair where its
hand mask covers at least 5 % of it (HAIR_SHOWN; the others show a man's short hair at the temples, 3-4 %).
Writes benchmarks/results/hair_found.md and hair_found.png (photo | hair found | Fast | Best, on default region 0;
then the same for the tight crop).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import MODELS, PHOTOS, delta_e, load_photo, show, subject, timed_match
from benchmarks.common import RESULTS, table
from benchmarks.hand_masks import load_records, rasterise

QUALITIES = ("fast", "better", "best")
TIGHT_WIDTH = 1.6  # face widths (the face detector's box) across a tight crop
HAIR_SHOWN = 0.05  # of a tight crop that its hand-drawn hair must cover for the crop to show hair


def finding(photo: np.ndarray) -> tuple[object, object, float, float]:
    """(the face, the hair found or the VtoError, face ms, hair ms), each timed warm (the second of two runs). The
    hair is found in the photo's light read beside the lips, as the product finds it (that reading is not timed)."""
    from blender_addon.shipped import photo_reader
    from vto_core.errors import VtoError
    from vto_core.photo.face_reader import cached_reader
    from vto_core.photo.photo_light import light_of

    reader = photo_reader()

    for _ in range(2):
        started = time.perf_counter()
        face = cached_reader(reader.detector, reader.landmarks).read(photo)  # not kept: each run reads it
        face_ms = 1000 * (time.perf_counter() - started)
        light = light_of(photo, reader.locate_lips(photo, face).mask) if face is not None else None
        started = time.perf_counter()
        try:
            hair = reader.locate_hair(photo, face, light) if face is not None else VtoError("no face")
        except VtoError as exc:
            hair = exc
        hair_ms = 1000 * (time.perf_counter() - started)
    return face, hair, face_ms, hair_ms


def overlay(photo: np.ndarray, found: np.ndarray | None, drawn: np.ndarray) -> np.ndarray:
    """The photo with the hair found tinted green and the hand mask's outline red."""
    out = photo.copy()
    if found is not None:
        out[found] = 0.55 * out[found] + 0.45 * np.array([0.0, 1.0, 0.0])
    edge = drawn & ~(np.roll(drawn, 1, 0) & np.roll(drawn, -1, 0) & np.roll(drawn, 1, 1) & np.roll(drawn, -1, 1))
    out[edge] = (1.0, 0.0, 0.0)
    return out


def run(records: list[dict], qualities: list[str], work: Path) -> tuple[list, list, dict, list]:
    """Rows of the finding table, rows of the estimate table, figures for the summary, the picture rows."""
    from blender_addon.matching.photo_fit import apparent_colour, region_renderer
    from vto_core.errors import VtoError
    from vto_core.imageio import write_image

    model = MODELS / "hair_encoder.onnx"
    drawn_masks = load_records()
    found_rows, estimate_rows, pictures = [], [], []
    figures = {"iou": [], "colour": [], "colour_drawn": [], "hair_ms": [], "face_ms": [], "mp": [], "held_out": [],
               "patches": [], "drawn_vs_patch": []}
    figures |= {f"{quality}{what}": [] for quality in qualities for what in ("", "_drawn", "_ms")}
    for record in records:
        photo = load_photo(record, PHOTOS.parent)
        height, width = photo.shape[:2]
        drawn = rasterise(drawn_masks[record["file"]], height, width)
        x, y, w, h = record["hair_patches"][0]
        patch_colour, drawn_colour = photo[y:y + h, x:x + w].reshape(-1, 3).mean(0), photo[drawn].mean(0)
        figures["drawn_vs_patch"].append(delta_e(drawn_colour, patch_colour))
        for x2, y2, w2, h2 in record["hair_patches"][1:2]:  # how far two hand patches of one hair lie apart
            figures["patches"].append(delta_e(photo[y2:y2 + h2, x2:x2 + w2].reshape(-1, 3).mean(0), patch_colour))
        face, hair, face_ms, hair_ms = finding(photo)
        found = hair.mask > 0.5 if hasattr(hair, "mask") else None
        iou = float((found & drawn).sum() / (found | drawn).sum()) if found is not None else 0.0
        found_colour = photo[found].mean(0) if found is not None else None
        colour = delta_e(found_colour, patch_colour) if found is not None else float("inf")
        colour_drawn = delta_e(found_colour, drawn_colour) if found is not None else float("inf")
        held = bool(record.get("held_out"))
        for key, value in (("iou", iou), ("colour", colour), ("colour_drawn", colour_drawn), ("hair_ms", hair_ms),
                           ("face_ms", face_ms), ("mp", height * width / 1e6), ("held_out", held)):
            figures[key].append(value)
        found_rows.append([subject(record), record.get("hair", "-"),
                           f"{width}x{height}", f"{iou:.2f}" if found is not None else f"refused: {hair}",
                           f"{colour:.1f}", f"{colour_drawn:.1f}", f"{face_ms:.0f}", f"{hair_ms:.0f}"])
        path = work / f"{Path(record['file']).stem.replace(':', '_').replace('/', '_')}.png"
        write_image(path, photo)
        cells = {"photo": show(photo), "found": show(overlay(photo, found, drawn))}
        for quality in qualities:
            try:
                result, ms = timed_match(model, path, quality)
            except VtoError as exc:  # refused: counted as the largest error, shown as a grey cell
                figures[quality].append(float("inf"))
                figures[f"{quality}_drawn"].append(float("inf"))
                figures[f"{quality}_ms"].append(float("nan"))
                estimate_rows.append([subject(record), quality, f"refused: {exc}", "-", "-"])
                continue
            apparent = apparent_colour("hair", result["params"])["mean"]
            error, error_drawn = delta_e(patch_colour, apparent), delta_e(drawn_colour, apparent)
            figures[quality].append(error)
            figures[f"{quality}_drawn"].append(error_drawn)
            figures[f"{quality}_ms"].append(ms)
            estimate_rows.append([subject(record), quality, f"{error:.1f}", f"{error_drawn:.1f}", f"{ms:,.0f}"])
            cells[quality] = show(region_renderer("hair", 0)(result["params"])[0])
        blank = np.full_like(cells["photo"], 0.16)
        pictures.append(np.concatenate([cells.get(k, blank) for k in ("photo", "found", "fast", "best")], 1))
        print(found_rows[-1], [row[2] for row in estimate_rows[-len(qualities):]], file=sys.stderr)
    return found_rows, estimate_rows, figures, pictures


def tight_crop(face, height: int, width: int) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the tight crop of a portrait (H, W) around its face (FaceRead): the face detector's box
    from top to bottom (the eyebrows to the chin), TIGHT_WIDTH box widths across its centre, inside the photo."""
    x, y, w, h = face.box
    centre = x + w / 2
    return (max(0, round(centre - TIGHT_WIDTH / 2 * w)), max(0, round(y)),
            min(width, round(centre + TIGHT_WIDTH / 2 * w)), min(height, round(y + h)))


def crop_row(record: dict, crop: np.ndarray, drawn: np.ndarray, qualities: list[str], work: Path, figures: dict
             ) -> tuple[list, np.ndarray]:
    """Finds the hair in a tight crop (H, W, 3) with its hand mask (H, W) and estimates it at each quality; appends
    to `figures`; (the table's row, the picture's cells photo | found | Fast | Best)."""
    from blender_addon.matching.photo_fit import apparent_colour, region_renderer
    from vto_core.errors import VtoError
    from vto_core.imageio import write_image

    _, hair, _, hair_ms = finding(crop)
    found = hair.mask > 0.5 if hasattr(hair, "mask") else None
    iou = float((found & drawn).sum() / (found | drawn).sum()) if found is not None else 0.0
    visible = crop[drawn].mean(0) if drawn.any() else crop.reshape(-1, 3).mean(0)
    colour = delta_e(crop[found].mean(0), visible) if found is not None else float("inf")
    for key, value in (("iou", iou), ("colour", colour), ("hair_ms", hair_ms), ("shown", drawn.mean()),
                       ("held_out", bool(record.get("held_out")))):
        figures[key].append(value)
    row = [subject(record), f"{crop.shape[1]}x{crop.shape[0]}", f"{drawn.mean():.0%}",
           f"{iou:.2f}" if found is not None else f"refused: {hair}", f"{colour:.1f}", f"{hair_ms:.0f}"]
    path = work / "crop.png"
    write_image(path, crop)
    cells = {"photo": show(crop), "found": show(overlay(crop, found, drawn))}
    for quality in qualities:
        try:
            result, ms = timed_match(MODELS / "hair_encoder.onnx", path, quality)
        except VtoError as exc:
            figures[quality].append(float("inf"))
            figures[f"{quality}_ms"].append(float("nan"))
            row += [f"refused: {exc}", "-"]
            continue
        figures[quality].append(delta_e(visible, apparent_colour("hair", result["params"])["mean"]))
        figures[f"{quality}_ms"].append(ms)
        row += [f"{figures[quality][-1]:.1f}", f"{ms:,.0f}"]
        cells[quality] = show(region_renderer("hair", 0)(result["params"])[0])
    blank = np.full_like(cells["photo"], 0.16)
    print(row, file=sys.stderr)
    return row, np.concatenate([cells.get(k, blank) for k in ("photo", "found", "fast", "best")], 1)


def run_crops(records: list[dict], qualities: list[str], work: Path) -> tuple[list, dict, list]:
    """Rows of the tight crops' table, their figures, their picture cells (one row per photo)."""
    from blender_addon.shipped import photo_reader

    drawn_masks = load_records()
    figures = {key: [] for key in ("iou", "colour", "hair_ms", "shown", "held_out")}
    figures |= {f"{quality}{what}": [] for quality in qualities for what in ("", "_ms")}
    rows, pictures = [], []
    for record in records:
        photo = load_photo(record, PHOTOS.parent)
        height, width = photo.shape[:2]
        x0, y0, x1, y1 = tight_crop(photo_reader().face_of(photo), height, width)
        drawn = rasterise(drawn_masks[record["file"]], height, width)[y0:y1, x0:x1]
        row, cells = crop_row(record, np.ascontiguousarray(photo[y0:y1, x0:x1]), drawn, qualities, work, figures)
        rows.append(row)
        pictures.append(cells)
    return rows, figures, pictures


def crop_summary(figures: dict, qualities: list[str]) -> list[list]:
    """Over the crops that show hair: all, the held-out and the tuning ones; IoU >= 0.5 and refusals counted,
    medians of the colours (a refusal counts as the largest error)."""
    held, shown = np.array(figures["held_out"]), np.array(figures["shown"]) >= HAIR_SHOWN
    iou, colour = np.array(figures["iou"]), np.array(figures["colour"])
    rows = []
    for label, keep in (("all", shown), ("held-out", shown & held), ("tuning", shown & ~held)):
        row = [f"{label} {keep.sum()} showing hair", f"{(iou[keep] >= 0.5).sum()}/{keep.sum()}",
               f"{(~np.isfinite(colour[keep])).sum()}", f"{np.median(iou[keep]):.2f}",
               f"{np.median(colour[keep]):.1f}"]
        row += [f"{np.median(np.array(figures[q])[keep]):.1f}, "
                f"{np.nanmedian(np.array(figures[q + '_ms'])[keep]):,.0f} ms" for q in qualities]
        rows.append(row)
    hairless = ~shown
    refused = (~np.isfinite(colour[hairless])).sum()
    rows.append([f"{hairless.sum()} showing little or no hair", "-", f"{refused}", "-", "-"] + ["-"] * len(qualities))
    return rows


def refusals(work: Path) -> list[list]:
    """What the hair path says of pictures with no hair to find: each should be one 'no hair found' line."""
    from blender_addon.matching.match import match
    from vto_core.errors import VtoError
    from vto_core.imageio import write_image

    import skimage.data

    astronaut = skimage.data.astronaut().astype(np.float32) / 255
    drawn = rasterise(load_records()["package:skimage.data.astronaut"], 512, 512)
    bald, hat = astronaut.copy(), astronaut.copy()
    bald[drawn] = astronaut[130:150, 200:250].reshape(-1, 3).mean(0)  # her forehead's skin over her hair
    hat[drawn] = (0.75, 0.1, 0.1)  # a red woollen hat over it
    records = json.loads(PHOTOS.read_text())
    desert = next(r for r in records if "desert" in r["file"])
    cases = {"a bald head (the astronaut's hair painted with her skin)": bald,
             "a hat (her hair painted red)": hat,
             "hair out of frame (the astronaut cut at her eyebrows)": astronaut[110:],
             "no person (the Great Sandy Desert from the ISS)": load_photo(desert, PHOTOS.parent),
             "noise": np.random.default_rng(0).random((256, 256, 3)).astype(np.float32),
             "a blank image": np.full((256, 256, 3), 0.5, np.float32)}
    rows = []
    for name, image in cases.items():
        path = work / "refusal.png"
        write_image(path, image)
        try:
            result = match(str(MODELS / "hair_encoder.onnx"), str(path))
            rows.append([name, f"NOT refused: {'; '.join(result['notes'])}"])
        except VtoError as exc:
            rows.append([name, str(exc)])
    return rows


def summary(figures: dict, qualities: list[str]) -> list[list]:
    """Medians over all photos, the held-out six and the twelve tuned on; colours 'against the patch (the mask)'."""
    held = np.array(figures["held_out"])
    rows = []
    for label, keep in (("all 18", np.ones_like(held)), ("held-out 6", held), ("tuning 12", ~held)):
        def median(key: str) -> float:
            return float(np.median(np.array(figures[key])[keep]))

        iou = np.array(figures["iou"])[keep]
        row = [label, f"{(iou >= 0.6).sum()}/{keep.sum()}", f"{np.median(iou):.2f}",
               f"{median('colour'):.1f} ({median('colour_drawn'):.1f})"]
        row += [f"{median(q):.1f} ({median(q + '_drawn'):.1f}), "
                f"{np.nanmedian(np.array(figures[q + '_ms'])[keep]):,.0f} ms" for q in qualities]
        rows.append(row)
    return rows


def whole_sections(found_rows: list, estimate_rows: list, figures: dict, qualities: list[str]) -> list[str]:
    """The markdown sections of the whole portraits."""
    per_mp = np.array(figures["hair_ms"]) / np.maximum(np.array(figures["mp"]), 1e-6)
    return [
        "## Whole portraits: summary (medians; CIEDE2000 against the hand patch's colour, and in brackets the hand "
        "mask's)\n\n" + table(["photos", "IoU >= 0.6", "IoU", "hair found"]
                               + [f"{q.title()} from the whole portrait" for q in qualities],
                               summary(figures, qualities)),
        f"Finding the hair (the face mesh apart): median {np.median(figures['hair_ms']):.0f} ms, largest "
        f"{max(figures['hair_ms']):.0f} ms on photos of {min(figures['mp']):.2f}-{max(figures['mp']):.2f} MP "
        f"(median {np.median(per_mp):.0f} ms per MP); the face reader: median {np.median(figures['face_ms']):.0f} ms.",
        "How far the reference itself spreads: the two hand patches of one hair (photos.json, the "
        f"{len(figures['patches'])} photos with two) lie a median {np.median(figures['patches']):.1f} CIEDE2000 apart "
        f"(largest {max(figures['patches'], default=0):.1f}); the mean of the whole hand-drawn hair lies a median "
        f"{np.median(figures['drawn_vs_patch']):.1f} from the first patch "
        f"(largest {max(figures['drawn_vs_patch']):.1f})."
        " A hair is lit and shaded across the head, and one patch is one place on it.",
        "## Hair found in the whole portraits\n\n" + table(
            ["photo", "hair", "size", "IoU with the hand mask", "found vs hand patch", "found vs hand mask", "face ms",
             "hair ms"], found_rows),
        "## From the whole portrait (CIEDE2000 of the estimate's apparent colour against the hand patch's)\n\n"
        + table(["photo", "quality", "against the hand patch", "against the hand mask's mean", "ms"],
                estimate_rows),
    ]


def crop_sections(rows: list, figures: dict, qualities: list[str]) -> list[str]:
    """The markdown sections of the tight crops."""
    return [
        f"## Tight crops: summary (crops whose hand mask covers at least {HAIR_SHOWN:.0%} of them; IoU with the "
        "hand mask cut alike; medians of CIEDE2000 against the mean colour of the hand-drawn hair in the crop, a "
        "refusal counted as the largest error)\n\n"
        + table(["crops", "IoU >= 0.5", "refused", "IoU", "hair found"]
                + [f"{q.title()} from the crop" for q in qualities], crop_summary(figures, qualities)),
        f"Finding the hair in the crops: median {np.median(figures['hair_ms']):.0f} ms.",
        "## Hair found in the tight crops (CIEDE2000 against the mean of the hand-drawn hair in the crop)\n\n"
        + table(["photo", "crop", "hand-drawn hair", "IoU with the hand mask", "found vs hand mask", "hair ms"]
                + [what for q in qualities for what in (f"{q.title()} vs hand mask", f"{q.title()} ms")], rows),
    ]


def main(argv: list[str] | None = None) -> None:
    """Run and write benchmarks/results/hair_found.md and .png."""
    from vto_core.imageio import write_image

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qualities", default="fast,better,best")
    parser.add_argument("--only", nargs="*", default=None, help="photo files to run (default: all with hair)")
    parser.add_argument("--sets", default="whole,crops", help="whole portraits, tight crops or both")
    args = parser.parse_args(argv)
    qualities = [q for q in args.qualities.split(",") if q]
    records = [r for r in json.loads(PHOTOS.read_text()) if r.get("hair_patches")]
    if args.only:
        records = [r for r in records if any(o in r["file"] for o in args.only)]
    sections, pictures = [], []
    with tempfile.TemporaryDirectory() as folder:
        if "whole" in args.sets:
            found_rows, estimate_rows, figures, pictures = run(records, qualities, Path(folder))
            sections += whole_sections(found_rows, estimate_rows, figures, qualities)
        if "crops" in args.sets:
            crop_rows, crop_figures, crop_pictures = run_crops(records, qualities, Path(folder))
            sections += crop_sections(crop_rows, crop_figures, qualities)
            pictures = [np.concatenate(cells, 1) for cells in zip(pictures, crop_pictures)] or crop_pictures
        sections.append("## Refusals\n\n" + table(["picture", "what the hair path says"], refusals(Path(folder))))
    text = "\n\n".join([
        "# Hair found in whole portraits and tight crops\n\n" + __doc__.split("\n\n", 2)[2].strip(), *sections,
        "Picture: `hair_found.png`, a row per photo: the photo | the hair found (green; the hand mask's outline red) "
        "| Fast | Best, each estimate on default hair region 0; then the same for its tight crop.",
    ])
    (RESULTS / "hair_found.md").write_text(text + "\n")
    if pictures:
        write_image(RESULTS / "hair_found.png", np.concatenate(pictures, 0))
    print(text)


if __name__ == "__main__":
    main()
