"""Headless commands that render one image: `vto render` (R(X, g) on a default-scene source) and `vto tryon` (a product
on a portrait); the same functions serve `blender -c vto`."""

from __future__ import annotations

import json
import os

from vto_core.cli import ArgumentParser, products_that
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.params_io import parse_params
from vto_core.products import PRODUCTS, either, get_spec, product_names

from .products import render


def cmd_render(argv: list[str]) -> int:
    """vto render RENDERER --params P --source S [--res 64] [--samples 16] [--seed 0] --out FILE."""
    parser = ArgumentParser(prog="vto render", description="render one image with a renderer R(X, g)")
    parser.add_argument("renderer", choices=product_names())
    parser.add_argument("--params", default=None, help="JSON object, a JSON file, or preset:NAME")
    parser.add_argument("--source", default="0", help=f"source seed, or ({products_that('photo_is_own_source')}) a "
                                                      "photo with <name>_mask beside it")
    parser.add_argument("--res", type=int, default=64)
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--seed", type=int, default=0, help="Cycles seed")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"],
                        help=f"{products_that('lightings')}: light the default scene's source as portraits are lit (a "
                             "frontal key, neutral, metered; the default) or the wide way (any HDRI, any rotation)")
    parser.add_argument("--out", required=True, help="image file (.png, .exr, .jpg, .tif)")
    args = parser.parse_args(argv)
    values = parse_params(args.params, args.renderer)
    image = render(args.renderer, values, args.source, args.res, args.samples, args.seed, args.lighting)
    write_image(args.out, image)
    print(json.dumps({"out": args.out, "renderer": args.renderer, "source": args.source, "params": values}))
    return 0


def tryon_params(text: str, renderer: str) -> dict[str, float]:
    """--params of `vto tryon`: what parse_params reads, or a preset's bare name ('Classic Red')."""
    from vto_core.presets import load_presets

    presets = load_presets(renderer)
    if text in presets:
        return presets[text]
    return parse_params(text, renderer)


def cmd_tryon(argv: list[str]) -> int:
    """vto tryon PRODUCT --image PHOTO --params P --out OUT [--crop [N]] [--samples 16] [--seed 0]."""
    from vto_core.imageio import read_image

    from ..renderers.products import blender_side

    tried_on = [p for p in PRODUCTS.values() if p.kind.tryon]
    parser = ArgumentParser(prog="vto tryon", description=f"draw a product ({products_that('tryon')}) onto a portrait")
    parser.add_argument("renderer", choices=[p.name for p in tried_on])
    parser.add_argument("--image", required=True, help="a portrait (any format the add-on reads)")
    parser.add_argument("--params", required=True,
                        help="a preset's name, preset:NAME, a JSON object or file (vto match's output too)")
    parser.add_argument("--out", required=True, help="image file (.png, .jpg, .tif, .exr)")
    parser.add_argument("--crop", type=int, nargs="?", const=64, default=None,
                        help=f"write the product's region ({either(p.region for p in tried_on)}; the first where it "
                             "has several) framed as Match frames it, N x N px (default 64), not the whole photo")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--seed", type=int, default=0, help="Cycles seed: a run is repeatable byte for byte")
    args = parser.parse_args(argv)
    if args.crop is not None and not 16 <= args.crop <= 1024:
        raise VtoError(f"--crop must be in [16, 1024] px, got {args.crop}")
    if not 1 <= args.samples <= 65536:
        raise VtoError(f"--samples must be in [1, 65536], got {args.samples}")
    values = get_spec(args.renderer).check_values(tryon_params(args.params, args.renderer))
    if not os.path.isfile(args.image):
        raise VtoError(f"no image at {args.image}")
    photo, _ = read_image(args.image)
    image = blender_side(args.renderer).tryon(photo, values, crop=args.crop, samples=args.samples, seed=args.seed)
    write_image(args.out, image)
    print(json.dumps({"out": args.out, "image": args.image, "size": list(image.shape[1::-1]), "params": values}))
    return 0
