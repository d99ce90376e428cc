"""`vto match`: a renderer's parameters from a reference image; the encoder's estimate, optionally refined.

Layering: this module needs onnxruntime (the encoder) and, for refinement, bpy (the renderer); it never imports torch
or `training`, because the extension ships without them. `--refine render:B` (a Gauss-Newton fit through the real
renderer, blender_addon.matching.refine; `cma:B` the derivative-free CMA-ES search) runs anywhere bpy does, inside
Blender too. `--refine imitator:K` is the pipeline layer's
(pipeline.match passes its refinement in as `imitator_refine`); without it, as inside Blender, it is one line.

Refinement compares renders of the reference's own source with the reference, so it needs that source: a seed of
the default scene (`--source SEED`), or for hair a photo with its `<name>_mask` beside it (the photo is its own
source). Without one the encoder's estimate is the answer, and the command says so.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from vto_core.cli import ArgumentParser
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.inference import EncoderSession
from vto_core.products import get_product, get_spec

from ..renderers.products import blender_side
from .photo_fit import NO_REGION, QUALITIES, fit_photo_fast, iter_fit_photo, photo_values
from .reference import at_size, read_reference
from .refine import OBJECTIVES, SIGMA, SIGMA_FROM_MEAN, drain, refine_by_render

NO_SOURCE = "no source for the reference (--source): refinement skipped, the encoder's estimate stands"
NO_IMITATOR = ("--refine imitator:K needs torch and the training package, which this Python lacks (e.g. inside "
               "Blender); use --refine render:B, or run `vto match` where torch is")


def parse_refine(text: str) -> tuple[str, int]:
    """'none' | 'imitator:K' | 'render:B' | 'cma:B' -> (kind, K or B)."""
    kind, _, amount = text.partition(":")
    if kind == "none" and not amount:
        return "none", 0
    if kind in ("imitator", "render", "cma") and amount.isdigit() and int(amount) >= 1:
        return kind, int(amount)
    raise VtoError(f"--refine takes none, imitator:K (K >= 1 gradient steps), render:B or cma:B (B >= 1 renders), "
                   f"got '{text}'")


class SourceRenderer:
    """R(X, .) on one fixed source X, at res px, `samples` spp and one Cycles seed: values -> (res, res, 3).

    source: a default-scene seed (int or digits), or where the product's photo is its own source (hair) a photo with
    its mask, rendered (or loaded) once here; `renders` counts the calls. lighting: the default scene's ("wide",
    "portrait"; None: its default) where the product has lightings (lips); the others have only their own.
    """

    def __init__(self, renderer: str, source, res: int, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                 lighting: str | None = None):
        self.spec = get_spec(renderer)
        self.res, self.samples, self.seed, self.renders, self.lighting = res, samples, seed, 0, lighting
        if lighting is not None and not get_product(renderer).lightings:
            from ..renderers.lighting import ONLY_LIPS

            raise VtoError(ONLY_LIPS)
        self.source, self.bound = source, blender_side(renderer).bind(source, res, samples, seed, lighting)

    def __call__(self, values: dict[str, float]) -> np.ndarray:
        values = self.spec.check_values(values)
        self.renders += 1
        return self.bound.render(values)

    def source_image(self) -> np.ndarray:
        """X as the imitator sees it (the dataset's 'source'): the bare lips (opacity 0), or the hair source."""
        self.renders += get_product(self.spec.renderer).renders_source
        return self.bound.source_image()


def own_source(product, image_path: Path) -> str | None:
    """The photo, where it is its own source: a product that says so (hair) and a '<name>_mask' image beside it."""
    if not product.photo_is_own_source:
        return None
    return str(image_path) if any(image_path.parent.glob(image_path.stem + "_mask.*")) else None


def match(model: str, image_path: str, source=None, refine: str = "none", imitator: str | None = None,
          res: int | None = None, samples: int = DEFAULT_SAMPLES, seed: int = 0, objective: str = "mse",
          start_at: str = "encoder", imitator_refine=None, lighting: str | None = None, quality: str = "fast",
          crop=None, mask_path: str | None = None, find_region: bool = True, neutral_light: bool = True) -> dict:
    """Estimate (and refine) the parameters of `image_path`.

    The reference is made ready as the panel makes it (blender_addon.matching.reference.read_reference): a crop, a mask,
    or the lips or the hair found in the photo (find_region; False takes the image as it is); a hair photo's
    '<name>_mask' beside it is its mask. With a `source` the image is a render of that source and is read whole.
    quality: "fast" (the encoder), "better" or "best" (the photo fit of blender_addon.matching.photo_fit, no source
    needed). refine: against a known source instead ('render:B', 'cma:B', 'imitator:K').
    Returns {'renderer', 'params': all parameters (raw values), 'refined', 'note', 'notes', 'encoder_ms'} (a photo:
    also 'fast_ms', the encoder's estimate fitted through the colour imitator) and, when
    refined, 'method', 'refine_ms', 'renders' or 'steps' (and 'loss_start', 'loss' for refine). res: the render size
    of render search (default: the reference's own, which must then be square). start_at: refinement starts at the
    'encoder' estimate or the 'mean' preset. imitator_refine: (spec, imitator run, source, reference, start unit, steps,
    samples, seed, lighting) -> a refinement with .unit, .loss, .start_loss, .steps; needed by imitator:K
    (pipeline.match gives it). lighting: the default lips scene's, for a lipstick --source (None: its default).
    neutral_light: a photo's light is read from its skin and taken out before the estimate (reference.lips_reference;
    'light' in the result); False reads the photo's colours as they are. A render of a known source is read as it is.
    """
    kind, amount = parse_refine(refine)
    quality = str(quality).upper()
    if quality not in QUALITIES:
        raise VtoError(f"--quality takes fast, better or best, got '{quality.lower()}'")
    if quality != "FAST" and kind != "none":
        raise VtoError("--quality better/best fits the photo's colour without its source; --refine refines against a "
                       "known --source: choose one")
    if kind == "imitator" and not imitator:
        raise VtoError("--refine imitator:K needs --imitator RUN (the imitator run the encoder was trained with)")
    if start_at not in ("encoder", "mean"):
        raise VtoError(f"--start takes encoder or mean, got '{start_at}'")
    if objective not in OBJECTIVES:
        raise VtoError(f"--objective takes {' or '.join(OBJECTIVES)}, got '{objective}'")
    session = EncoderSession(model)
    spec = session.spec
    product = get_product(spec.renderer)
    if source is None and mask_path is None and crop is None:
        beside = own_source(product, Path(image_path))
        if beside:
            from ..renderers.hair import mask_path_for

            mask_path = str(mask_path_for(Path(image_path)))
    settings = {"image_path": image_path, "crop": crop, "mask_path": mask_path,
                "find_region": find_region and source is None,
                "neutral_light": neutral_light and source is None}
    prepared = read_reference(spec.renderer, settings)
    started = time.perf_counter()
    values = session.predict(prepared.image)[0]
    result = {"renderer": spec.renderer, "params": values, "refined": False, "note": "", "notes": prepared.notes,
              "encoder_ms": 1000 * (time.perf_counter() - started)}
    turn = round(math.degrees(prepared.turn), 1)  # the face's roll the region was read upright from
    if prepared.lips is not None:
        result["lips"] = {"how": prepared.lips.how, "box": list(prepared.lips.box), "faces": prepared.lips.faces,
                          "turn": turn}
    if prepared.hair is not None:
        result["hair"] = {"box": list(prepared.hair.box), "faces": prepared.hair.faces,
                          "share": round(float(prepared.hair.mask.mean()), 4), "turn": turn}
    if prepared.light is not None:
        result["light"] = {"gains": [round(float(g), 4) for g in prepared.light.gains],
                           "read_from": prepared.light.read_from}
    encoder = {k: values[k] for k in spec.modelled}  # Better and Best's candidate starts: it and Fast's
    if source is None and prepared.region is not None:  # a photo: Fast (hair: its colour, through the colour imitator)
        fast, note = fit_photo_fast(spec, prepared.region, encoder, quality=quality)
        result["notes"] = prepared.notes + ([note] if note else [])
        result["params"] = values = spec.full_values(photo_values(spec, fast))
        result["fast_ms"] = 1000 * (time.perf_counter() - started)  # the encoder (and, for hair, the colour fit)
    if quality != "FAST":
        if prepared.region is None:
            raise VtoError(f"--quality {quality.lower()} {NO_REGION} (not --whole-image)")
        started = time.perf_counter()
        renders = []
        fitted = drain(iter_fit_photo(spec, prepared.region, encoder, quality, samples=samples,
                                      others=({k: values[k] for k in spec.modelled},),
                                      photo=(prepared.whole, prepared.lips)),
                       renders.append)
        result.update(params=spec.full_values(photo_values(spec, fitted)), refined=True, method=quality.lower(),
                      renders=renders[-1],
                      refine_ms=1000 * (time.perf_counter() - started))
        return result
    if kind == "none":
        return result
    if source is None:
        source = own_source(product, Path(image_path))
    if source is None:
        result["note"] = NO_SOURCE
        return result
    reference = prepared.whole
    if start_at == "mean":
        from vto_core.presets import load_presets, preset_matrix

        start_unit = preset_matrix(spec, load_presets(spec.renderer)).mean(axis=0)
    else:
        start_unit = spec.normalise(spec.vector(values))
    wraps = np.array([p.wraps for p in spec.modelled_params])
    started = time.perf_counter()
    if kind in ("render", "cma"):
        if res is None:
            if reference.shape[0] != reference.shape[1]:
                raise VtoError(f"{image_path} is {reference.shape[1]}x{reference.shape[0]}; renders are square: pass "
                               "--res R to compare at R x R")
            res = reference.shape[0]
        on_source = SourceRenderer(spec.renderer, source, res, samples, seed, lighting)
        held = None
        if on_source.bound.own_photo and Path(str(source)).resolve() == Path(image_path).resolve():
            held = blender_side(product).fit_held(spec, spec.values(spec.denormalise(start_unit)))
        refined = refine_by_render(lambda u: on_source(spec.values(spec.denormalise(u))), at_size(reference, res, res),
                                   start_unit, amount, seed, wraps, objective,
                                   SIGMA_FROM_MEAN if start_at == "mean" else SIGMA, held,
                                   "fit" if kind == "render" and objective == "mse" else "cma")
        result["renders"] = refined.renders
    else:
        if imitator_refine is None:
            raise VtoError(NO_IMITATOR)
        refined = imitator_refine(spec, imitator, source, reference, start_unit, amount, samples, seed, lighting)
        result["steps"] = refined.steps
    result.update(params=spec.values(spec.denormalise(refined.unit)), refined=True, method=refine,
                  refine_ms=1000 * (time.perf_counter() - started), loss_start=refined.start_loss, loss=refined.loss)
    return result


def cmd_match(argv: list[str], imitator_refine=None) -> int:
    """vto match --model M --image IMG [--quality fast|better|best] [--crop x,y,w,h] [--mask IMG] [--whole-image]
    [--source S --refine none|imitator:K|render:B|cma:B] [--imitator RUN] --out-params F,
    or vto match --material NAME --image IMG [--model M] [--quality Q] [--crop] [--mask] [--blend FILE] --save.

    The same function serves `blender -b [FILE] -c vto match`; there imitator:K ends in one line (no torch). The
    console script runs it through pipeline.match, which passes `imitator_refine` (match's).
    With --material the estimate goes into that material's "VTO Lipstick" group inputs (blender_addon.matching.apply,
    the operator's code) and --save writes the .blend atomically; on any error the file is left as it was.
    """
    parser = ArgumentParser(prog="vto match", description="estimate a renderer's parameters from a reference image")
    parser.add_argument("--model", default=None, help="an encoder exported with `vto export` (with --material: "
                                                      "default the shipped lipstick encoder)")
    parser.add_argument("--image", required=True, help="the reference image")
    parser.add_argument("--source", default=None, help="the reference's source: a default-scene seed, or a hair "
                                                      "photo with a mask (default: the image itself, for hair)")
    parser.add_argument("--refine", default="none", help="none (encoder only), imitator:K (K gradient steps through "
                                                         "the imitator, needs torch), render:B (a fit through the "
                                                         "renderer, B renders; CMA-ES with --objective ssim) or cma:B "
                                                         "(CMA-ES, B renders)")
    parser.add_argument("--imitator", default=None, help="imitator run folder, for --refine imitator:K")
    parser.add_argument("--res", type=int, default=None, help="render size of render search (default: the reference's)")
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES, help="Cycles samples of refinement renders")
    parser.add_argument("--seed", type=int, default=0, help="Cycles seed of every refinement render")
    parser.add_argument("--objective", default="mse", choices=sorted(OBJECTIVES), help="render search: mse or 1-SSIM")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"],
                        help="lipstick: the default lips scene's lighting of --source (default portrait)")
    parser.add_argument("--start", default="encoder", choices=["encoder", "mean"],
                        help="refinement starts at the encoder's estimate or at the mean preset")
    parser.add_argument("--out-params", default=None, help="JSON file for the estimate (takes `vto render --params`)")
    parser.add_argument("--material", default=None, help="write the estimate into this material's VTO Lipstick group "
                                                         "inputs (of --blend FILE, or the open .blend)")
    parser.add_argument("--blend", default=None, help="with --material: the .blend to open (default: the open one)")
    parser.add_argument("--save", action="store_true", help="with --material: save the .blend (atomically)")
    parser.add_argument("--quality", default="fast", choices=["fast", "better", "best"],
                        help="the panel's choice: fast (the encoder, milliseconds), better or best (its estimate "
                             "fitted through the renderer to the colour of the photo's lips or hair; seconds)")
    parser.add_argument("--crop", default=None, help="x,y,w,h of the reference to use, from the top-left, in pixels "
                                                     "or fractions")
    parser.add_argument("--mask", default=None, help="a mask image: of the lips (the reference is framed around them "
                                                     "as the default scene frames its lips) or of the hair")
    parser.add_argument("--whole-image", action="store_true",
                        help="take the image (or crop) as it is instead of finding the lips or the hair in it")
    parser.add_argument("--preview", default=None,
                        help="lipstick: an image of the photo | the estimate tried on the photo | the estimate on the "
                             "default lips (.png or .jpg)")
    parser.add_argument("--keep-light", action="store_true",
                        help="lipstick: read the photo's colours as they are, its light included (default: the light "
                             "is read from the skin beside the lips and taken out)")
    args = parser.parse_args(argv)
    if args.material is None:
        for option in ("blend", "save"):
            if getattr(args, option):
                raise VtoError(f"--{option} goes with --material NAME")
        if args.out_params is None or args.model is None:
            raise VtoError("give --model M and --out-params FILE, or --material NAME --save")
    elif not args.save:
        raise VtoError("--material writes into the .blend: add --save (nothing is kept otherwise)")
    out = Path(args.out_params) if args.out_params else None
    if out is not None and not out.resolve().parent.is_dir():
        raise VtoError(f"--out-params: no folder {out.parent}")
    if args.material is not None:
        return match_material_cli(args, out)
    if args.res is not None and not 8 <= args.res <= 4096 or not 1 <= args.samples <= 65536:
        raise VtoError(f"--res must be in [8, 4096] and --samples in [1, 65536], got {args.res} and {args.samples}")
    mask = os.path.abspath(args.mask) if args.mask else None
    if args.preview is not None and not Path(args.preview).resolve().parent.is_dir():
        raise VtoError(f"--preview: no folder {Path(args.preview).parent}")
    result = match(args.model, args.image, args.source, args.refine, args.imitator, args.res, args.samples, args.seed,
                   args.objective, args.start, imitator_refine, args.lighting, args.quality, parse_crop(args.crop),
                   mask, not args.whole_image, not args.keep_light)
    sheet = None if args.preview is None else preview(result, args.image, args.samples, args.seed)
    for note in [result["note"], *result["notes"]]:
        if note:
            print(f"vto match: {note}", file=sys.stderr)
    temporary = out.with_name(out.name + ".tmp")
    temporary.write_text(json.dumps({"renderer": result["renderer"], "params": result["params"]}, indent=1) + "\n")
    if sheet is not None:
        write_image(args.preview, sheet)
    temporary.replace(out)
    print(json.dumps({"out": str(out), **result}))
    return 0


PREVIEW_SIZE = 256  # px: each panel of `vto match --preview`


def preview(result: dict, image_path: str, samples: int, seed: int) -> np.ndarray:
    """(PREVIEW_SIZE, 3 PREVIEW_SIZE, 3): the photo around its lips | the estimate tried on it | the estimate on the
    default lips (source 0); VtoError for hair, or a photo without a face to try it on."""
    from .reference import load_reference

    product = get_product(result["renderer"])
    if not product.tryon:
        raise VtoError(f"--preview shows a product tried on the photo: {product.name} has no try-on yet")
    side = blender_side(product)
    panels = list(side.tryon_view(load_reference(image_path), result["params"], PREVIEW_SIZE, samples, seed))
    panels.append(side.render(result["params"], 0, PREVIEW_SIZE, samples, seed))
    return np.concatenate(panels, axis=1)


def parse_crop(text: str | None) -> tuple[float, ...] | None:
    """'x,y,w,h' -> four floats (checked against the image later), or None."""
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4:
        raise VtoError(f"--crop takes x,y,w,h (four numbers, pixels or fractions), got '{text}'")
    return values


def match_material_cli(args, out: Path | None) -> int:
    """`vto match --material NAME --save`: the operator's code (blender_addon.matching.apply), then an atomic save."""
    if args.refine != "none":
        raise VtoError("--material takes --quality (the panel's choice), not --refine: the material's photo has no "
                       "source to render")
    crop = parse_crop(args.crop)
    import bpy

    from .apply import match_into_material
    from ..blendfile import open_blend, save_blend_atomic

    open_blend(args.blend)
    blend = bpy.data.filepath
    settings = {"image_path": os.path.abspath(args.image), "model_path": os.path.abspath(args.model) if args.model
                else "", "crop": crop, "mask_path": os.path.abspath(args.mask) if args.mask else "",
                "quality": args.quality.upper(), "find_region": not args.whole_image,
                "neutral_light": not args.keep_light}
    result = match_into_material(args.material, settings)
    for warning in result["warnings"]:
        print(f"vto match: warning: {warning}", file=sys.stderr)
    for note in result["notes"]:
        print(f"vto match: {note}", file=sys.stderr)
    save_blend_atomic(blend)
    if out is not None:
        temporary = out.with_name(out.name + ".tmp")
        temporary.write_text(json.dumps({"renderer": result["spec"].renderer, "params": result["values"]}, indent=1)
                             + "\n")
        temporary.replace(out)
    print(json.dumps({"blend": blend, "material": args.material, "model": result["model"],
                      "params": result["values"], "seconds": round(result["seconds"], 4)}))
    return 0
