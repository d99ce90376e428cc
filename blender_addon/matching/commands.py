"""`vto match`: a reference image's parameters as JSON (blender_addon.matching.match), or written into a material
(`--material`, blender_addon.matching.apply) and saved; `--preview` shows the estimate tried on the photo. The same
function serves `blender -b [FILE] -c vto match`; the console script runs it through pipeline.match."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np

from vto_core.cli import ArgumentParser, products_that
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.photo.photo_reader import load_reference
from vto_core.products import PRODUCTS, either, get_product, product_list

from ..renderers.products import blender_side
from .match import match
from .refine import OBJECTIVES


def cmd_match(argv: list[str], imitator_refine=None) -> int:
    """vto match --model M --image IMG [--quality fast|better|best] [--crop x,y,w,h] [--mask IMG] [--whole-image]
    [--source S --refine none|imitator:K|render:B|cma:B] [--imitator RUN] --out-params F,
    or vto match --material NAME [--layer PRODUCT] --image IMG [--model M] [--quality Q] [--crop] [--mask]
    [--blend FILE] --save.

    The same function serves `blender -b [FILE] -c vto match`; there imitator:K ends in one line (no torch). The
    console script runs it through pipeline.match, which passes `imitator_refine` (match's).
    With --material the estimate goes into that material's "VTO Lipstick" group inputs (blender_addon.matching.apply,
    the operator's code) and --save writes the .blend atomically; on any error the file is left as it was.
    """
    materials = [p for p in PRODUCTS.values() if p.is_material]
    regions = either(p.region for p in PRODUCTS.values())
    own_source = products_that("photo_is_own_source")
    parser = ArgumentParser(prog="vto match", description="estimate a renderer's parameters from a reference image")
    parser.add_argument("--model", default=None, help="an encoder exported with `vto export` (with --material: "
                                                      "default the shipped encoder of the material's product, "
                                                      f"{product_list(materials)})")
    parser.add_argument("--image", required=True, help="the reference image")
    parser.add_argument("--source", default=None, help="the reference's source: a default-scene seed, or a "
                                                      f"{own_source} photo with a mask (default: the image itself, "
                                                      f"for {own_source})")
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
                        help=f"{products_that('lightings')}: the default scene's lighting of --source (default "
                             "portrait)")
    parser.add_argument("--start", default="encoder", choices=["encoder", "mean"],
                        help="refinement starts at the encoder's estimate or at the mean preset")
    parser.add_argument("--out-params", default=None, help="JSON file for the estimate (takes `vto render --params`)")
    parser.add_argument("--material", default=None, help="write the estimate into the inputs of this material's "
                                                         f"group ({either(p.group_text for p in materials)}) (of "
                                                         "--blend FILE, or the open .blend)")
    parser.add_argument("--layer", default=None, choices=[p.name for p in materials],
                        help="with --material: the product to fill where the material wears several makeup layers "
                             "(default: its active node's, else the first)")
    parser.add_argument("--blend", default=None, help="with --material: the .blend to open (default: the open one)")
    parser.add_argument("--save", action="store_true", help="with --material: save the .blend (atomically)")
    parser.add_argument("--quality", default="fast", choices=["fast", "better", "best"],
                        help="the panel's choice: fast (the encoder, milliseconds), better or best (its estimate "
                             f"fitted through the renderer to the colour of the photo's {regions}; seconds)")
    parser.add_argument("--crop", default=None, help="x,y,w,h of the reference to use, from the top-left, in pixels "
                                                     "or fractions")
    framed = [p for p in PRODUCTS.values() if p.face_regions]
    parser.add_argument("--mask", default=None, help=f"a mask image of the product's region ({regions}; "
                                                     f"{product_list(framed)}: the reference is framed around it as "
                                                     "the default scene frames it)")
    parser.add_argument("--whole-image", action="store_true",
                        help=f"take the image (or crop) as it is instead of finding the {regions} in it")
    parser.add_argument("--preview", default=None,
                        help=f"{products_that('tryon')}: an image of the photo | the estimate tried on the photo | "
                             "the estimate on the default scene (.png or .jpg)")
    parser.add_argument("--keep-light", action="store_true",
                        help="read the photo's colours as they are, its light included (default: the light is read "
                             "from the face's skin and taken out)")
    args = parser.parse_args(argv)
    if args.material is None:
        for option in ("blend", "save", "layer"):
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
    product = get_product(result["renderer"])
    if not product.kind.tryon:
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
    result = match_into_material(args.material, settings, product=get_product(args.layer) if args.layer else None)
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


def cmd_find_face(argv: list[str]) -> int:
    """vto find-face --mesh FILE [--object NAME] [--scene-camera] [--group REGION=GROUP ...] [--preview PNG]
    --out OUT.blend."""
    parser = ArgumentParser(prog="vto find-face", description="find the face on a head (or body) mesh and write its "
                            "regions as the attributes the makeup layers read; saves a .blend with the mesh")
    parser.add_argument("--mesh", required=True, help="a .blend, .obj, .glb/.gltf or .fbx")
    parser.add_argument("--object", default=None, help="the mesh object (default: the file's largest mesh)")
    parser.add_argument("--scene-camera", action="store_true", help="see the face from the scene's camera (default: "
                        "the mesh's own front, back or sides, whichever shows a face)")
    parser.add_argument("--group", action="append", default=[], metavar="REGION=GROUP",
                        help="a vertex group that already says where a region is (lips=Lips): its weights are used")
    parser.add_argument("--preview", default=None, help="PNG: the front render with the landmarks found")
    parser.add_argument("--out", required=True, help="the .blend to write")
    args = parser.parse_args(argv)
    groups = {}
    for given in args.group:
        region, _, group = given.partition("=")
        if not region or not group:
            raise VtoError(f"--group takes REGION=GROUP, got '{given}'")
        groups[region] = group
    if not args.out.endswith(".blend"):
        raise VtoError(f"--out must be a .blend, got {args.out}")
    import time

    import bpy

    from ..blendfile import mesh_object, open_mesh_file, save_blend_atomic
    from .face_on_mesh import drawn_landmarks, find_face, place_camera

    open_mesh_file(args.mesh)
    obj = mesh_object(args.object)
    camera = bpy.context.scene.camera if args.scene_camera else None
    if args.scene_camera and camera is None:
        raise VtoError(f"{args.mesh} has no scene camera")
    start = time.perf_counter()
    found = find_face(obj, camera, groups)
    seconds = time.perf_counter() - start
    place_camera(bpy.context.scene, obj, found.view)
    if args.preview:
        write_image(args.preview, drawn_landmarks(found))
    for note in found.notes:
        print(f"vto find-face: {note}", file=sys.stderr)
    out = save_blend_atomic(args.out)
    print(json.dumps({"out": out, "object": obj.name, "vertices": len(obj.data.vertices), "regions": found.counts,
                      "seconds": round(seconds, 3)}))
    return 0
