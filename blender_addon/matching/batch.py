"""`vto batch`: a folder of product photos -> one preset per product, the median of its photos' estimates (paper 7.3).

OUT receives: estimates/<image>.json (one per photo, written atomically and reused by a rerun while the photo and the
model are unchanged), presets.json and presets.csv (the shipped presets' format: `vto render --params
preset:NAME@OUT/presets.json` takes them), assets.blend with blender_assets.cats.txt (a material product, lipstick or
eye shadow: one asset material per product with a rendered preview; hair has none, see blender_addon.datasets.assets),
sheet.png (one row per product: its first photo | its preset tried on that photo's face regions | a render of its
preset) and report.json (products, their photos, and every photo skipped with the reason).

The median is per parameter, in raw units; a wrapping parameter (hair hue) takes the circular median: the photo's
value whose summed distance around the circle to the others is least.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

from vto_core.cli import ArgumentParser
from vto_core.dataset import DEFAULT_SAMPLES, write_text_atomic
from vto_core.errors import VtoError, failure_line
from vto_core.imageio import write_image
from vto_core.inference import EncoderSession
from vto_core.photo.photo_reader import at_size
from vto_core.products import get_product
from vto_core.specs import ParamSpec, RendererSpec

from ..renderers.products import blender_side
from .match import own_source
from .colour_fit import fit_photo_fast
from .photo_fit import photo_values
from .reference import read_reference

ESTIMATES = "estimates"
READER = 3  # how photos are read (3: the light read from the skin and taken out, lips Fast the encoder): older
# estimates are redone
CHUNK = 32  # photos per encoder call
TRYON_SAMPLES = 8  # Cycles samples of a try-on cell at most (as the panel's preview): one try-on per product row
BLANK = 0.5  # the grey of a try-on cell where there is none (hair, or a photo without a face)


def circular_median(values, low: float, high: float) -> float:
    """The sample of `values` on the circle [low, high) with the least summed arc distance to all of them."""
    values = np.asarray(values, dtype=np.float64)
    span = high - low
    gaps = np.abs(values[:, None] - values[None, :]) % span
    return float(values[np.argmin(np.minimum(gaps, span - gaps).sum(axis=1))])


def median_values(spec: RendererSpec, rows: list[dict[str, float]]) -> dict[str, float]:
    """Per-parameter median of estimates (all parameters); circular for wrapping ones."""
    def one(param: ParamSpec) -> float:
        column = [row[param.name] for row in rows]
        return circular_median(column, param.low, param.high) if param.wraps else float(np.median(column))

    return {param.name: one(param) for param in spec.params}


def list_images(folder: str) -> list[Path]:
    """The folder's files (not hidden, not '<photo>_mask.*' beside a photo), sorted; errors if none or no folder."""
    root = Path(folder)
    if not root.is_dir():
        raise VtoError(f"--images: no folder {folder}")
    files = sorted(p for p in root.iterdir() if p.is_file() and not p.name.startswith("."))
    stems = {p.stem for p in files}
    files = [p for p in files if not (p.stem.endswith("_mask") and p.stem[:-len("_mask")] in stems)]
    if not files:
        raise VtoError(f"--images: {folder} holds no files")
    return files


def regex_grouping(pattern: str):
    """--group-by: image path -> product (the first capture group, or the whole match, of the stem) or None."""
    try:
        compiled = re.compile(pattern)
    except re.error as exc:
        raise VtoError(f"--group-by: bad regular expression '{pattern}': {exc}") from None

    def product(path: Path) -> str | None:
        found = compiled.search(path.stem)
        if found is None:
            return None
        return (found.group(1) if compiled.groups else found.group(0)) or None

    return product


def csv_grouping(csv_path: str):
    """--groups: a CSV with columns image,product (image: file name or stem) -> image path -> product or None."""
    try:
        with open(csv_path, newline="", encoding="utf-8-sig") as handle:
            reader = csv.DictReader(handle)
            if not reader.fieldnames or not {"image", "product"} <= {f.strip() for f in reader.fieldnames}:
                raise VtoError(f"--groups: {csv_path} needs a header with columns image,product")
            rows = [{k.strip(): (v or "").strip() for k, v in row.items() if k} for row in reader]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise VtoError(f"--groups: cannot read {csv_path}: {exc}") from None
    table = {}
    for line, row in enumerate(rows, start=2):
        if not row.get("image") or not row.get("product"):
            raise VtoError(f"--groups: {csv_path} line {line} lacks an image or a product")
        table[row["image"]] = row["product"]
    if not table:
        raise VtoError(f"--groups: {csv_path} lists no images")
    return lambda path: table.get(path.name, table.get(path.stem))


def model_fingerprint(path: str) -> str:
    """SHA-256 of the model file: cached estimates are reused only for the same model."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _cache_key(image: Path, fingerprint: str) -> dict:
    stat = image.stat()
    return {"image": image.name, "bytes": stat.st_size, "mtime_ns": stat.st_mtime_ns, "model": fingerprint,
            "reader": READER}


def fast_values(spec, reference, values: dict[str, float]) -> dict[str, float]:
    """What Fast writes for a photo: the encoder's `values`, for hair fitted through the colour imitator (where the
    photo's region is known), with what a photo fixes (blender_addon.matching.colour_fit.fit_photo_fast)."""
    if reference.region is not None:
        values = fit_photo_fast(spec, reference.region, {k: values[k] for k in spec.modelled})[0]
    return spec.full_values(photo_values(spec, values))


def no_tryon_line(product) -> str:
    """Why a product's row of the sheet has no try-on."""
    return f"{product.name} has no try-on yet"


def batch_reference(renderer: str, image: Path):
    """A photo of the folder made ready as the panel makes it (blender_addon.matching.reference.read_reference): its
    face regions found (the lips, both eyes' lids), or the hair (its '<name>_mask' beside it wins; else the hair found
    around a face, or a patch of hair with no face read whole)."""
    mask = next(iter(sorted(image.parent.glob(image.stem + "_mask.*"))), None)
    return read_reference(renderer, {"image_path": str(image), "mask_path": str(mask) if mask else ""})


def cached_estimate(out: Path, image: Path, fingerprint: str) -> dict[str, float] | None:
    """The estimate stored for `image` by an earlier run with the same model, or None."""
    try:
        record = json.loads((out / ESTIMATES / f"{image.name}.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    return record.get("params") if record.get("key") == _cache_key(image, fingerprint) else None


def progress(total: int, quiet: bool):
    """A tqdm bar of images/s on stderr, on a terminal only (no carriage returns in logs)."""
    from tqdm import tqdm

    return tqdm(total=total, unit="image", desc="batch", dynamic_ncols=True, disable=quiet or not sys.stderr.isatty())


def estimate_images(session: EncoderSession, images: list[Path], out: Path, fingerprint: str, quiet: bool = True):
    """Estimate every image (cached ones reused): returns ({name: values}, [{'image', 'reason'}], n_cached)."""
    (out / ESTIMATES).mkdir(parents=True, exist_ok=True)
    estimates, skipped, todo = {}, [], []
    for image in images:
        cached = cached_estimate(out, image, fingerprint)
        if cached is not None:
            estimates[image.name] = cached
        else:
            todo.append(image)
    with progress(len(todo), quiet) as bar:
        for start in range(0, len(todo), CHUNK):
            loaded = {}
            for image in todo[start:start + CHUNK]:
                try:
                    loaded[image] = batch_reference(session.spec.renderer, image)
                except VtoError as exc:
                    skipped.append({"image": image.name, "reason": str(exc)})
            if loaded:
                for (image, reference), values in zip(loaded.items(),
                                                      session.predict_views([r.images for r in loaded.values()])):
                    values = fast_values(session.spec, reference, values)
                    estimates[image.name] = values
                    record = {"key": _cache_key(image, fingerprint), "renderer": session.spec.renderer,
                              "params": values}
                    write_text_atomic(out / ESTIMATES / f"{image.name}.json", json.dumps(record, indent=1) + "\n")
            bar.update(len(todo[start:start + CHUNK]))
    return estimates, skipped, len(images) - len(todo)


def write_presets(out: Path, renderer: str, presets: dict[str, dict[str, float]]) -> list[str]:
    """presets.json (the shipped presets' format) and presets.csv (name, then one column per parameter)."""
    rows = [{"name": name, "params": values} for name, values in presets.items()]
    write_text_atomic(out / "presets.json", json.dumps({"renderer": renderer, "presets": rows}, indent=1) + "\n")
    names = list(next(iter(presets.values())))
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["name", *names])
    writer.writerows([name, *(repr(values[key]) for key in names)] for name, values in presets.items())
    write_text_atomic(out / "presets.csv", text.getvalue())
    return [str(out / "presets.json"), str(out / "presets.csv")]


def group_products(images: list[Path], grouping) -> tuple[dict[str, list[Path]], list[dict]]:
    """product -> its images (in order), and the images no product claims (with the reason)."""
    products, unclaimed = {}, []
    for image in images:
        name = grouping(image) if grouping else image.stem
        if name:
            products.setdefault(name, []).append(image)
        else:
            unclaimed.append({"image": image.name, "reason": "no product: --group-by does not match its name, "
                                                            "or --groups does not list it"})
    return products, unclaimed


def parse_args(argv: list[str]):
    """The command line, checked before anything is written."""
    parser = ArgumentParser(prog="vto batch", description="estimate a folder of product photos: one preset per "
                                                          "product (median of its photos), an asset library, a sheet")
    parser.add_argument("--model", required=True, help="an encoder exported with `vto export`")
    parser.add_argument("--images", required=True, help="folder of photos")
    parser.add_argument("--out", required=True, help="output folder (rerunning into it reuses finished estimates)")
    grouping = parser.add_mutually_exclusive_group()
    grouping.add_argument("--group-by", default=None, help="regex on the file stem: its first group names the product")
    grouping.add_argument("--groups", default=None, help="CSV with columns image,product")
    parser.add_argument("--source", default="0", help="default-scene seed the presets are rendered on")
    parser.add_argument("--res", type=int, default=64, help="render size of the sheet and previews")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--seed", type=int, default=0, help="Cycles seed")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if not 8 <= args.res <= 1024 or not 1 <= args.samples <= 65536:
        raise VtoError(f"--res must be in [8, 1024] and --samples in [1, 65536], got {args.res} and {args.samples}")
    if not str(args.source).isdigit():
        raise VtoError(f"--source is a seed of the default scene (an integer), got '{args.source}'")
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise VtoError(f"--out: {args.out} is a file, not a folder")
    return args


def render_products(renderer: str, presets: dict, products: dict[str, list[Path]], args) -> dict[str, np.ndarray]:
    """A render of each preset: on default scene `--source`, or on its first photo where that is its own source
    (hair, with a mask)."""
    from ..renderers.products import render

    product = get_product(renderer)
    return {name: render(renderer, values, own_source(product, products[name][0]) or args.source,
                         args.res, args.samples, args.seed) for name, values in presets.items()}


def sheet_cells(renderer: str, presets: dict, products: dict[str, list[Path]], args
                ) -> tuple[dict[str, np.ndarray], dict[str, tuple[np.ndarray, np.ndarray]], dict[str, str]]:
    """What the sheet shows of each product's first photo: ({product: the photo as the encoder read it}, {product:
    (the photo around its face regions, its preset tried on them)} (renderers.tryon.tryon_view at --res px, at most
    TRYON_SAMPLES samples), {product: why it has no try-on}). One photo is read at a time; hair, a photo with no
    face, or a try-on that fails leaves a product without a try-on, never failing the batch."""
    product = get_product(renderer)
    references, tryons, missing = {}, {}, {}
    for name, paths in products.items():
        reference = batch_reference(renderer, paths[0])
        references[name] = reference.image
        if not product.kind.tryon:
            missing[name] = no_tryon_line(product)
            continue
        try:
            tryons[name] = blender_side(product).tryon_view(reference.whole, presets[name], args.res,
                                                            min(args.samples, TRYON_SAMPLES), args.seed)
        except Exception as exc:  # VtoError 'no face found ...', or a render that failed: the sheet goes on
            missing[name] = failure_line(exc)
    return references, tryons, missing


def contact_sheet(path: Path, references: dict[str, np.ndarray], renders: dict[str, np.ndarray], res: int,
                  tryons: dict[str, tuple[np.ndarray, np.ndarray]] | None = None) -> str:
    """One row per product: its first photo | its preset tried on it | the render of its preset, each res x res.
    Where the product has a try-on (sheet_cells) the photo is shown around its face regions as the try-on is (the two
    cells differ only on the regions); else its reference resized, and the try-on cell is BLANK grey."""
    tryons = tryons or {}
    blank = np.full((res, res, 3), BLANK, np.float32)
    rows = [np.concatenate([*(tryons[name] if name in tryons else (at_size(references[name], res, res), blank)),
                            renders[name]], axis=1) for name in renders]
    return write_image(path, np.concatenate(rows, axis=0))


def cmd_batch(argv: list[str]) -> int:
    """vto batch --model M --images DIR --out OUT [--group-by REGEX | --groups CSV] [--res 64] [--samples 16]."""
    args = parse_args(argv)
    grouping = regex_grouping(args.group_by) if args.group_by else csv_grouping(args.groups) if args.groups else None
    images = list_images(args.images)
    session = EncoderSession(args.model)
    spec, out = session.spec, Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    estimates, skipped, cached = estimate_images(session, images, out, model_fingerprint(args.model), args.quiet)
    seconds = time.perf_counter() - started
    products, unclaimed = group_products([p for p in images if p.name in estimates], grouping)
    skipped += unclaimed
    for row in skipped:
        print(f"vto batch: skipped {row['image']}: {row['reason']}", file=sys.stderr)
    report = {"model": args.model, "renderer": spec.renderer, "images": len(images), "estimated": len(estimates),
              "cached": cached, "images_per_s": round((len(estimates) - cached) / seconds, 2) if seconds else None,
              "skipped": skipped, "products": {name: [p.name for p in paths] for name, paths in products.items()}}
    if not products:
        write_text_atomic(out / "report.json", json.dumps(report, indent=1) + "\n")
        raise VtoError(f"no photo in {args.images} could be estimated and given a product; see {out / 'report.json'}")
    presets = {name: median_values(spec, [estimates[p.name] for p in paths]) for name, paths in products.items()}
    report["presets"] = write_presets(out, spec.renderer, presets)
    renders = render_products(spec.renderer, presets, products, args)
    references, tryons, no_tryon = sheet_cells(spec.renderer, presets, products, args)
    for name, reason in no_tryon.items():
        if reason != no_tryon_line(get_product(spec.renderer)):
            print(f"vto batch: {name}: no try-on on the sheet: {reason}", file=sys.stderr)
    report["sheet"] = contact_sheet(out / "sheet.png", references, renders, args.res, tryons)
    report["sheet_rows"] = list(renders)
    report["sheet_columns"] = ["photo", "try-on", "render"]
    report["sheet_no_tryon"] = no_tryon
    product = get_product(spec.renderer)
    if product.kind.asset_library:
        from ..datasets.assets import write_library

        library = {name: (presets[name], renders[name], []) for name in presets}
        report["materials"] = write_library(out / "assets.blend", library, f"Estimated by {Path(args.model).name}",
                                            product)
        report["asset_library"] = str(out / "assets.blend")
    else:
        report["asset_library"] = None
        report["asset_library_skipped"] = product.no_library
    write_text_atomic(out / "report.json", json.dumps(report, indent=1) + "\n")
    print(json.dumps({"out": str(out), "products": len(presets), "estimated": len(estimates), "cached": cached,
                      "skipped": len(skipped), "images_per_s": report["images_per_s"]}))
    return 0
