"""Hand-drawn hair masks of the real photos: polygons in benchmarks/photos/hair_masks.json, rasterised here.

    python -m benchmarks.hand_masks --show FILE --out sheet.png [--grid 50] [--region X0,Y0,X1,Y1]
        # the photo (or a region of it), its drawn polygons, a grid labelled in the photo's own pixels

Each record: {"file": as in photos.json, "polygons": [[[x, y], ...], ...], "holes": [...]} in the pixel coordinates
of the photo as loaded (x right, y down). The mask is the union of the polygons less the union of the holes.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.bench_real_photos import PHOTOS, load_photo

MASKS = PHOTOS.parent / "hair_masks.json"


def load_records(path: Path = MASKS) -> dict[str, dict]:
    """The drawn masks by photo file name."""
    if not path.exists():
        return {}
    return {record["file"]: record for record in json.loads(path.read_text())}


def rasterise(record: dict, height: int, width: int) -> np.ndarray:
    """(H, W) bool: the record's polygons less its holes."""
    from skimage.draw import polygon

    mask = np.zeros((height, width), bool)
    for key, value in (("polygons", True), ("holes", False)):
        for points in record.get(key, []):
            points = np.asarray(points, float)
            rows, cols = polygon(points[:, 1], points[:, 0], (height, width))
            mask[rows, cols] = value
    return mask


def sheet(image: np.ndarray, mask: np.ndarray | None, grid: int, region: tuple[int, int, int, int] | None = None
          ) -> np.ndarray:
    """(h, w, 3) the photo (or region x0, y0, x1, y1 of it) with the mask tinted green, its outline red, and a
    labelled grid every `grid` px of the photo."""
    from skimage.segmentation import find_boundaries

    out = image[..., :3].copy()
    if mask is not None and mask.any():
        out[mask] = 0.6 * out[mask] + 0.4 * np.array([0.0, 1.0, 0.0])
        out[find_boundaries(mask, mode="inner")] = (1.0, 0.0, 0.0)
    out[::grid, :] = 0.5 * out[::grid, :] + 0.5 * np.array([0.0, 0.8, 1.0])
    out[:, ::grid] = 0.5 * out[:, ::grid] + 0.5 * np.array([0.0, 0.8, 1.0])
    x0, y0, x1, y1 = region or (0, 0, out.shape[1], out.shape[0])
    return _label_grid(out[y0:y1, x0:x1], grid, x0, y0)


def _label_grid(out: np.ndarray, grid: int, x0: int, y0: int) -> np.ndarray:
    """Writes each grid line's photo coordinate beside it (matplotlib's text, so the sheet can be read off)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    height, width = out.shape[:2]
    figure = plt.figure(figsize=(width / 100, height / 100), dpi=100)
    axes = figure.add_axes((0, 0, 1, 1))
    axes.imshow(np.clip(out, 0, 1))
    axes.set_axis_off()
    for x in range(-x0 % grid, width, grid):
        axes.text(x + 1, 8, str(x + x0), color="yellow", fontsize=6)
    for y in range(-y0 % grid or grid, height, grid):
        axes.text(1, y - 1, str(y + y0), color="yellow", fontsize=6)
    figure.canvas.draw()
    pixels = np.asarray(figure.canvas.buffer_rgba())[..., :3].astype(np.float32) / 255
    plt.close(figure)
    return pixels


def main(argv: list[str] | None = None) -> None:
    """Writes a sheet of one photo with its drawn mask (if any) and a grid, to draw or check a mask by eye."""
    from vto_core.imageio import write_image

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--show", required=True, help="a file name as in photos.json")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--grid", type=int, default=50)
    parser.add_argument("--masks", type=Path, default=MASKS)
    parser.add_argument("--region", help="x0,y0,x1,y1: show this part of the photo only")
    args = parser.parse_args(argv)
    record = next(r for r in json.loads(PHOTOS.read_text()) if r["file"] == args.show)
    image = load_photo(record, PHOTOS.parent)
    drawn = load_records(args.masks).get(args.show)
    mask = rasterise(drawn, *image.shape[:2]) if drawn else None
    region = tuple(int(v) for v in args.region.split(",")) if args.region else None
    write_image(args.out, sheet(image, mask, args.grid, region))
    if mask is not None:
        print(f"{args.show}: {int(mask.sum())} px drawn ({mask.mean():.1%} of the photo)")


if __name__ == "__main__":
    main()
