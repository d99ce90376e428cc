"""Headless commands that need Blender (`vto render`, ...); the same functions serve `blender -c vto`."""

from __future__ import annotations

import argparse
import json
import os

from vto_core.cli import ArgumentParser
from vto_core.dataset import DEFAULT_RES, DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.imageio import write_image
from vto_core.params_io import parse_params
from vto_core.products import PRODUCTS, get_product, get_spec, product_names


def render(renderer: str, values: dict[str, float], source, res: int = 64, samples: int = DEFAULT_SAMPLES,
           seed: int = 0, lighting: str | None = None):
    """R(X, g) of product `renderer`: (res, res, 3) display-sRGB float32; values are checked strictly.

    lighting: the default scene's, "wide" or "portrait" (None: the default), where the product has lightings (lips);
    the others have only their own.
    """
    from ..renderers.products import blender_side

    values = get_spec(renderer).check_values(values)
    product = get_product(renderer)
    if lighting is not None and not product.lightings:
        from ..renderers.lighting import ONLY_LIPS

        raise VtoError(ONLY_LIPS)
    return blender_side(product).render(values, source, res, samples, seed, lighting)


def cmd_render(argv: list[str]) -> int:
    """vto render RENDERER --params P --source S [--res 64] [--samples 16] [--seed 0] --out FILE."""
    parser = ArgumentParser(prog="vto render", description="render one image with a renderer R(X, g)")
    parser.add_argument("renderer", choices=product_names())
    parser.add_argument("--params", default=None, help="JSON object, a JSON file, or preset:NAME")
    parser.add_argument("--source", default="0", help="source seed, or (hair) a photo with <name>_mask beside it")
    parser.add_argument("--res", type=int, default=64)
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--seed", type=int, default=0, help="Cycles seed")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"],
                        help="lipstick: light the default scene's source as portraits are lit (a frontal key, "
                             "neutral, metered; the default) or the wide way (any HDRI, any rotation)")
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

    parser = ArgumentParser(prog="vto tryon", description="draw a product (a lipstick) onto a portrait")
    parser.add_argument("renderer", choices=[p.name for p in PRODUCTS.values() if p.tryon])
    parser.add_argument("--image", required=True, help="a portrait (any format the add-on reads)")
    parser.add_argument("--params", required=True,
                        help="a preset's name, preset:NAME, a JSON object or file (vto match's output too)")
    parser.add_argument("--out", required=True, help="image file (.png, .jpg, .tif, .exr)")
    parser.add_argument("--crop", type=int, nargs="?", const=64, default=None,
                        help="write the lips framed as Match frames them, N x N px (default 64), not the whole photo")
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


def _launcher() -> list[str]:
    """How to start another `vto` like this one: the Blender binary (`blender -b FILE -c vto`) or this Python."""
    import os
    import sys

    import bpy

    binary = bpy.app.binary_path
    if binary and os.path.basename(binary).lower().startswith("blender"):
        return [binary, "-b", *([bpy.data.filepath] if bpy.data.filepath else []), "-c", "vto"]
    return [sys.executable, "-m", "vto_core.cli"]


def _user_scene() -> str | None:
    """The open .blend's active scene if a material of it uses the lipstick group (else the default scene)."""
    import bpy

    from ..renderers.lipstick import makeup_nodes

    if not bpy.data.filepath:
        return None
    scene = bpy.context.scene
    return scene.name if scene is not None and makeup_nodes(scene) else None


def cmd_dataset(argv: list[str]) -> int:
    """vto dataset RENDERER --out DIR --n N --seed S [--shard i/K] [--res] [--samples] [--params] [--sensitivity] [--workers W]."""
    import bpy

    from vto_core.dataset import parse_shard, shard_from_env, shard_range

    from .dataset import DatasetJob, prepare_output, run_in_process, run_workers, worker_indices

    parser = ArgumentParser(prog="vto dataset", description="render a training dataset (paper 5.2, 6.1)")
    parser.add_argument("renderer", choices=product_names())
    parser.add_argument("--out", required=True)
    parser.add_argument("--n", type=int, required=True, help="samples in the whole dataset (all shards)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--shard", default=None, help="i/K; default from SLURM_ARRAY_TASK_ID/COUNT or JOB_COMPLETION_INDEX")
    parser.add_argument("--res", type=int, default=None, help=f"default {DEFAULT_RES}; a --blend scene's own")
    parser.add_argument("--samples", type=int, default=None, help=f"default {DEFAULT_SAMPLES}; a --blend scene's own")
    parser.add_argument("--params", default=None, help="comma-separated parameters to model (default: the spec's); "
                                                          "'auto' with --blend: those that visibly change the scene")
    parser.add_argument("--sensitivity", action="store_true", help="also render R(X, g'_j) for each modelled j")
    parser.add_argument("--no-source", action="store_true",
                        help="write no source image X (lipstick: render none): half the renders of a look, for "
                             "encoder data trained with the graphics loss only (the imitator needs X)")
    parser.add_argument("--uniform-ratio", type=float, default=0.5, help="share of uniform draws vs the preset fit")
    parser.add_argument("--source-folder", default=None, help="hair: photos with <name>_mask beside them")
    parser.add_argument("--looks-per-source", type=int, default=1,
                        help="hair, default scene: this many consecutive looks share one source render (the stage "
                             "costs ~7 ms a look, a hair render ~1 s)")
    parser.add_argument("--masks", action="store_true",
                        help="lipstick, default scene: also write each look's lips mask (what a colour imitator "
                             "reads; hair datasets always hold their hair mask)")
    parser.add_argument("--blend", default=None, help="lipstick: a .blend whose active scene uses the VTO Lipstick group")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"],
                        help="lipstick, default scene: portrait (a frontal key, neutral light, metered exposure; the "
                             "default) or wide (any HDRI, any rotation)")
    parser.add_argument("--vary", default="", help="comma-separated unmodelled inputs to draw uniformly over their "
                                                    "ranges per look (e.g. gloss_roughness), so the encoder learns to "
                                                    "look past them")
    parser.add_argument("--photos", default=None,
                        help="lipstick: try each look on a portrait of this folder (its faces.json's train split "
                             "where it has one) and write it as Match reads the photo, not on the default scene")
    parser.add_argument("--workers", type=int, default=1, help="Blender processes on this machine")
    parser.add_argument("--restart-every", type=int, default=500, help="samples per worker process before a restart")
    parser.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--limit", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    if args.workers < 1:
        raise VtoError(f"--workers must be at least 1, got {args.workers}")
    if args.blend:
        from ..blendfile import open_blend

        open_blend(args.blend)
    user_scenes = get_product(args.renderer).user_scenes
    scene = _user_scene() if user_scenes else None
    if args.blend and user_scenes and scene is None:
        raise VtoError(f"{args.blend}: no material of its active scene uses the 'VTO Lipstick' node group")
    params = args.params.split(",") if args.params else None
    if args.params == "auto":
        if scene is None:
            raise VtoError("--params auto needs --blend: it models the inputs that visibly change the user's scene")
        from ..renderers.scene_params import visible_parameters

        params = [row["name"] for row in visible_parameters(bpy.data.scenes[scene], args.res, args.samples)
                  if row["visible"]]
        if not params:
            raise VtoError(f"no lipstick input visibly changes {args.blend}: nothing to model")
    shard = parse_shard(args.shard) if args.shard else shard_from_env()
    job = DatasetJob(args.renderer, args.out, args.n, args.seed, args.res, args.samples, params, args.sensitivity,
                     args.uniform_ratio, args.source_folder, scene, args.lighting, not args.no_source,
                     tuple(name for name in args.vary.split(",") if name), args.looks_per_source, args.masks,
                     args.photos)
    indices = shard_range(job.n, shard)
    if args.worker is not None:  # one of run_workers' processes: its share of the shard, then exit
        run_in_process(job, worker_indices(indices, parse_shard(args.worker)), args.limit, quiet=True)
        return 0
    prepare_output(job)
    if args.workers == 1:
        made = run_in_process(job, indices, args.limit, args.quiet)
    else:
        forwarded = [a for a in argv if a not in ("--quiet",)]
        for option in ("--workers", "--shard", "--limit", "--params"):
            forwarded = _drop_option(forwarded, option)
        forwarded += ["--shard", f"{shard[0]}/{shard[1]}", "--params", ",".join(job.spec.modelled)]
        made = run_workers(job, indices, args.workers, _launcher() + ["dataset", *forwarded], args.restart_every,
                           args.quiet)
    print(json.dumps({"out": args.out, "shard": f"{shard[0]}/{shard[1]}", "indices": [indices.start, indices.stop],
                      "made": made}))
    return 0


def _drop_option(argv: list[str], name: str) -> list[str]:
    """argv without `name VALUE` (or `name=VALUE`)."""
    out, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg == name:
            skip = True
        elif not arg.startswith(name + "="):
            out.append(arg)
    return out
