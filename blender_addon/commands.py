"""Headless commands that need Blender (`vto render`, ...); the same functions serve `blender -c vto`."""

from __future__ import annotations

import argparse
import json

from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.params_io import parse_params
from vto_core.specs import get_spec


def render(renderer: str, values: dict[str, float], source, res: int = 64, samples: int = 16, seed: int = 0):
    """R(X, g) for either renderer: (res, res, 3) display-sRGB float32; values are checked strictly."""
    values = get_spec(renderer).check_values(values)
    if renderer == "lipstick":
        from .lipstick import render_lipstick

        if not (isinstance(source, int) or str(source).isdigit()):
            raise VtoError(f"lipstick sources are seeds of the default lips scene (an integer), got '{source}'")
        return render_lipstick(values, int(source), res, samples, seed)
    from .hair import render_hair

    return render_hair(values, source, res, samples, seed)


def cmd_render(argv: list[str]) -> int:
    """vto render RENDERER --params P --source S [--res 64] [--samples 16] [--seed 0] --out FILE."""
    parser = argparse.ArgumentParser(prog="vto render", description="render one image with a renderer R(X, g)")
    parser.add_argument("renderer", choices=["lipstick", "hair"])
    parser.add_argument("--params", default=None, help="JSON object, a JSON file, or preset:NAME")
    parser.add_argument("--source", default="0", help="source seed, or (hair) a photo with <name>_mask beside it")
    parser.add_argument("--res", type=int, default=64)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--seed", type=int, default=0, help="Cycles seed")
    parser.add_argument("--out", required=True, help="image file (.png, .exr, .jpg, .tif)")
    args = parser.parse_args(argv)
    values = parse_params(args.params, args.renderer)
    image = render(args.renderer, values, args.source, args.res, args.samples, args.seed)
    write_image(args.out, image)
    print(json.dumps({"out": args.out, "renderer": args.renderer, "source": args.source, "params": values}))
    return 0
