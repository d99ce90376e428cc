"""`vto match`: parameters from a reference image, the encoder's estimate optionally refined through the renderer.

Refinement compares renders of the reference's own source with the reference, so it needs that source: a seed
of the default scene (`--source`), or for hair a photo with its `<name>_mask` beside it (the photo is its own
source). Without one the encoder's estimate is the answer, and the command says so.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from vto_core.cli import ArgumentParser
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import read_image, resize
from vto_core.inference import EncoderSession

from .commands import render


def parse_refine(text: str) -> tuple[str, int]:
    """'none' | 'render:B' -> (kind, budget)."""
    kind, _, amount = text.partition(":")
    if kind == "none" and not amount:
        return "none", 0
    if kind == "render" and amount.isdigit() and int(amount) >= 1:
        return "render", int(amount)
    if kind == "imitator":
        raise VtoError("--refine imitator:K is not built yet; use none or render:B")
    raise VtoError(f"--refine takes none or render:B (B renders, >= 1), got '{text}'")


def photo_source(image_path: Path) -> str | None:
    """A hair photo is its own source when a '<name>_mask' image lies beside it."""
    return str(image_path) if any(image_path.parent.glob(image_path.stem + "_mask.*")) else None


def match(model: str, image_path: str, source: str | None = None, refine: str = "none", res: int = 64,
          samples: int = DEFAULT_SAMPLES, seed: int = 0) -> dict:
    """Estimate (and refine) the parameters of `image_path`: {'params', 'refined', 'note', timings}."""
    session = EncoderSession(model)
    spec = session.spec
    kind, budget = parse_refine(refine)
    reference, _ = read_image(image_path)
    if reference.ndim != 3 or reference.shape[0] < 8 or reference.shape[1] < 8:
        raise VtoError(f"{image_path}: image is {reference.shape[1]}x{reference.shape[0]}; at least 8x8 is needed")
    start = time.perf_counter()
    values = session.predict(reference)[0]
    result = {"params": values, "refined": False, "note": "", "encoder_ms": 1000 * (time.perf_counter() - start)}
    if kind == "none":
        return result
    if source is None and spec.renderer == "hair":
        source = photo_source(Path(image_path))
    if source is None:
        result["note"] = "no source for the reference (--source): refinement skipped, the encoder's estimate stands"
        return result
    from .refine import refine_by_render

    target = resize(np.clip(np.nan_to_num(reference, nan=0.0), 0, 1), res, res) if reference.shape[:2] != (res, res) \
        else np.clip(reference, 0, 1)
    source = int(source) if str(source).isdigit() else source

    def render_unit(unit):
        return render(spec.renderer, spec.values(spec.denormalise(unit)), source, res, samples, seed)

    start = time.perf_counter()
    refined = refine_by_render(render_unit, target, spec.normalise(spec.vector(values)), budget, seed)
    result.update(params=spec.values(spec.denormalise(refined.unit)), refined=True,
                  refine_ms=1000 * (time.perf_counter() - start), renders=refined.renders,
                  loss_start=refined.start_loss, loss=refined.loss)
    return result


def cmd_match(argv: list[str]) -> int:
    """vto match --model M --image IMG [--source S] [--refine none|render:B] [--res] [--samples] --out-params FILE."""
    parser = ArgumentParser(prog="vto match", description="estimate a renderer's parameters from a reference image")
    parser.add_argument("--model", required=True, help="an encoder exported with `vto export`")
    parser.add_argument("--image", required=True, help="the reference image")
    parser.add_argument("--source", default=None, help="the reference's source: a default-scene seed, or a hair "
                                                      "photo with a mask (default: the image itself, for hair)")
    parser.add_argument("--refine", default="none", help="none (encoder only) or render:B (CMA-ES, B renders)")
    parser.add_argument("--res", type=int, default=64, help="render size for refinement")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--out-params", required=True, help="JSON file for the estimate (takes `vto render --params`)")
    args = parser.parse_args(argv)
    if not os.path.isfile(args.image):
        raise VtoError(f"no image at {args.image}")
    if not Path(args.out_params).resolve().parent.is_dir():
        raise VtoError(f"--out-params: no folder {Path(args.out_params).parent}")
    result = match(args.model, args.image, args.source, args.refine, args.res, args.samples)
    if result["note"]:
        print(f"vto match: {result['note']}", file=sys.stderr)
    out = Path(args.out_params)
    temporary = out.with_name(out.name + ".tmp")
    temporary.write_text(json.dumps({"params": result["params"]}, indent=1))
    temporary.replace(out)
    print(json.dumps({"out": str(out), **result}))
    return 0
