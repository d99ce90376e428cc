"""How much of the lips the face mesh's inner lip contour leaves out, beside what a dark product reads there.

    PYTHONPATH=. .venv/bin/python scripts/experiments/measure_lips_gap.py --cache out/st_s64.jsonl [--product "Goth Black Matte"]
        [--picture benchmarks/results/skin_tones_lips_gap.png --faces 062 070 044 [--then out/st_s65c.jsonl]]

The lips are the face mesh's outer lip contour less its inner one; on a closed mouth the mesh often leaves a gap
between the inner contours, which the try-on left bare until the locator closed it (lips_locator.closed_mouth). For
each face of bench_skin_tones' --cache (its tried-on photos beside it): the share of the outer contour's area inside
the mesh's own inner contour, how lips-like that area is (CIEDE2000 of its median colour to the lips' median, on the
bare photo), and Fast's and Better's L* error on the product there. Prints one line per face, the correlation and the
two halves' medians; with --picture, one row per face of --faces: the bare photo with the mesh's contours drawn, the
product tried on as --cache has it, and as --then has it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from blender_addon.shipped import photo_reader
from vto_core.colour import ciede2000, srgb_to_lab
from vto_core.imageio import read_image
from vto_core.photo.face_regions import region_mask, region_polygons
from vto_core.products import LIPS


def drawn(photo: np.ndarray, worn: list[np.ndarray], outer: np.ndarray, inner: np.ndarray,
          margin: int = 30) -> Image.Image:
    """The bare photo with the outer (green) and inner (blue) contours (K, 2) | each tried-on photo, about the lips."""
    bare = Image.fromarray((np.clip(photo, 0, 1) * 255).astype(np.uint8))
    draw = ImageDraw.Draw(bare)
    for polygon, colour in ((outer, (0, 255, 0)), (inner, (0, 128, 255))):
        points = [tuple(map(float, p)) for p in polygon]
        draw.line(points + points[:1], fill=colour, width=1)
    x0, y0 = (int(v) - margin for v in outer.min(axis=0))
    x1, y1 = (int(v) + margin for v in outer.max(axis=0))
    tiles = [bare] + [Image.fromarray((np.clip(image, 0, 1) * 255).astype(np.uint8)) for image in worn]
    row = Image.new("RGB", (len(tiles) * (x1 - x0), y1 - y0))
    for column, tile in enumerate(tiles):
        row.paste(tile.crop((x0, y0, x1, y1)), (column * (x1 - x0), 0))
    return row


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", required=True, help="bench_skin_tones' --cache (its tried-on photos beside it)")
    parser.add_argument("--product", default="Goth Black Matte")
    parser.add_argument("--picture")
    parser.add_argument("--faces", nargs="*", default=[], help="London numbers of the picture's rows")
    parser.add_argument("--then", help="another run's cache: its tried-on photos in the picture's last column")
    args = parser.parse_args(argv)
    cache = Path(args.cache)
    rows = {}
    for line in cache.read_text().splitlines():
        row = json.loads(line)
        rows[row["face"], row["product"]] = row
    found_lines, pictured = [], {}
    for (face, product), row in sorted(rows.items()):
        if product != args.product or "better" not in row["estimates"]:
            continue
        photo = read_image(face)[0][..., :3]
        outer_line, inner_line = region_polygons(photo_reader().face_of(photo).landmarks, LIPS)  # the mesh's own
        outer, inner = (region_mask([line], *photo.shape[:2])[0] > 0.5 for line in (outer_line, inner_line))
        lab = srgb_to_lab(np.clip(photo, 0.0, 1.0))
        share = float(inner.sum() / outer.sum())
        like = float(ciede2000(np.median(lab[inner], 0), np.median(lab[outer & ~inner], 0))) if inner.any() else np.nan
        fast, better = (row["estimates"][m]["lab"][0] - row["truth"][0] for m in ("fast", "better"))
        found_lines.append((share, like, fast, better, Path(face).stem, row["group"]))
        number = Path(face).stem.split("_")[1]
        if number in args.faces:
            name = f"{Path(face).stem}_{product.replace(' ', '_')}.png"
            worn = [read_image(Path(run).with_suffix("") / name)[0][..., :3] for run in (cache, args.then) if run]
            pictured[number] = drawn(photo, worn, outer_line, inner_line)
    found_lines.sort()
    for line in found_lines:
        print("inner share %.2f  inner to lips CIEDE2000 %5.1f  L* error Fast %+5.1f Better %+5.1f  %s (%s)" % line)
    share, fast, better = (np.array([line[i] for line in found_lines]) for i in (0, 2, 3))
    big = share >= np.median(share)
    print(f"{len(share)} faces: correlation of the share with the L* error: Fast {np.corrcoef(share, fast)[0, 1]:.2f}, "
          f"Better {np.corrcoef(share, better)[0, 1]:.2f}; median L* error where the share >= {np.median(share):.2f}: "
          f"Fast {np.median(fast[big]):+.1f}, Better {np.median(better[big]):+.1f}; below: Fast "
          f"{np.median(fast[~big]):+.1f}, Better {np.median(better[~big]):+.1f}")
    if args.picture and pictured:
        pictures = [pictured[n] for n in args.faces if n in pictured]
        sheet = Image.new("RGB", (max(p.width for p in pictures), sum(p.height for p in pictures)))
        top = 0
        for picture in pictures:
            sheet.paste(picture, (0, top))
            top += picture.height
        sheet.save(args.picture)


if __name__ == "__main__":
    main()
