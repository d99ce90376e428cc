"""`vto dataset`: a training dataset rendered headless; the same function serves `blender -c vto dataset`."""

from __future__ import annotations

import argparse
import json

from vto_core.cli import ArgumentParser, products_that
from vto_core.dataset import DEFAULT_RES, DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.products import PRODUCTS, either, get_product, product_names


def _launcher() -> list[str]:
    """How to start another `vto` like this one: the Blender binary (`blender -b FILE -c vto`) or this Python."""
    import os
    import sys

    import bpy

    binary = bpy.app.binary_path
    if binary and os.path.basename(binary).lower().startswith("blender"):
        return [binary, "-b", *([bpy.data.filepath] if bpy.data.filepath else []), "-c", "vto"]
    return [sys.executable, "-m", "vto_core.cli"]


def _user_scene(product) -> str | None:
    """The open .blend's active scene if a material of it uses `product`'s group (else the default scene)."""
    import bpy

    from ..renderers.products import blender_side

    if not bpy.data.filepath:
        return None
    scene = bpy.context.scene
    return scene.name if scene is not None and blender_side(product).scene_nodes(scene) else None


def cmd_dataset(argv: list[str]) -> int:
    """vto dataset RENDERER --out DIR --n N --seed S [--shard i/K] [--res] [--samples] [--params] [--sensitivity] [--workers W]."""
    import os

    import bpy

    from vto_core.dataset import parse_shard, shard_from_env, shard_range

    from .dataset import DatasetJob, prepare_output, run_in_process, run_workers, terminate_as_exit, worker_indices

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
                        help=f"write no source image X ({products_that('renders_source')}: render none): half the "
                             "renders of a look, for encoder data trained with the graphics loss only (the imitator "
                             "needs X)")
    parser.add_argument("--uniform-ratio", type=float, default=0.5, help="share of uniform draws vs the preset fit")
    parser.add_argument("--preset-kernel", type=float, default=0.0,
                        help="0: the preset fit is one normal on the presets (the paper's); above 0, a normal of this "
                             "width (unit range) about each preset, which keeps the dark and light ends the presets "
                             "have")
    parser.add_argument("--without-presets", default="",
                        help="comma-separated presets the sampler leaves out (a benchmark's products, kept unseen)")
    parser.add_argument("--uniform-lightness", action="store_true",
                        help="each uniform draw's colour moved to a lightness drawn evenly over CIELAB L* 0-100, its "
                             "hue kept: dark and light products as common as middling ones (the RGB cube puts 3 %% "
                             "of its colours below L* 20)")
    parser.add_argument("--uniform-params", default="",
                        help="comma-separated parameters the uniform draws spread (default: all); the others come "
                             "from a preset draw, so a colour drawn anywhere is worn with a finish products have")
    parser.add_argument("--source-folder", default=None,
                        help=f"{products_that('photo_is_own_source')}: photos with <name>_mask beside them")
    parser.add_argument("--looks-per-source", type=int, default=1,
                        help=f"{products_that('shared_sources')}, default scene: this many consecutive looks share "
                             "one source render (hair's stage costs ~7 ms a look, a hair render ~1 s)")
    parser.add_argument("--masks", action="store_true",
                        help=f"{products_that('masks')}, default scene: also write each look's "
                             f"{either(p.region for p in PRODUCTS.values() if p.kind.masks)} mask (what a colour "
                             f"imitator reads; {products_that('masks', False)} datasets always hold their mask)")
    parser.add_argument("--blend", default=None,
                        help=f"{products_that('user_scenes')}: a .blend whose active scene uses the product's group ("
                             f"{either(p.group_text for p in PRODUCTS.values() if p.kind.user_scenes)})")
    parser.add_argument("--lighting", default=None, choices=["wide", "portrait"],
                        help=f"{products_that('lightings')}, default scene: portrait (a frontal key, neutral light, "
                             "metered exposure; the default) or wide (any HDRI, any rotation)")
    parser.add_argument("--vary", default="", help="comma-separated unmodelled inputs to draw uniformly over their "
                                                    "ranges per look (e.g. gloss_roughness), so the encoder learns to "
                                                    "look past them")
    parser.add_argument("--photos", default=None,
                        help=f"{products_that('photo_datasets')}: try each look on a portrait of this folder (its "
                             "faces.json's train split where it has one) and write it as Match reads the photo, not "
                             "on the default scene")
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
    user_scenes = get_product(args.renderer).kind.user_scenes
    scene = _user_scene(get_product(args.renderer)) if user_scenes else None
    if args.blend and user_scenes and scene is None:
        raise VtoError(f"{args.blend}: no material of its active scene uses the "
                       f"{get_product(args.renderer).group_text}")
    params = args.params.split(",") if args.params else None
    if args.params == "auto":
        if scene is None:
            raise VtoError("--params auto needs --blend: it models the inputs that visibly change the user's scene")
        from ..renderers.scene_params import visible_parameters

        params = [row["name"] for row in visible_parameters(bpy.data.scenes[scene], args.res, args.samples)
                  if row["visible"]]
        if not params:
            raise VtoError(f"no {args.renderer} input visibly changes {args.blend}: nothing to model")
    shard = parse_shard(args.shard) if args.shard else shard_from_env()
    job = DatasetJob(args.renderer, args.out, args.n, args.seed, args.res, args.samples, params, args.sensitivity,
                     args.uniform_ratio, args.source_folder, scene, args.lighting, not args.no_source,
                     tuple(name for name in args.vary.split(",") if name), args.looks_per_source, args.masks,
                     args.photos, args.preset_kernel, tuple(name for name in args.without_presets.split(",") if name),
                     args.uniform_lightness, tuple(name for name in args.uniform_params.split(",") if name))
    indices = shard_range(job.n, shard)
    if args.worker is not None:  # one of run_workers' processes: its share of the shard, then exit
        run_in_process(job, worker_indices(indices, parse_shard(args.worker)), args.limit, quiet=True,
                       parent=os.getppid())
        return 0
    prepare_output(job, indices)
    if args.workers == 1:
        made = run_in_process(job, indices, args.limit, args.quiet)
    else:
        forwarded = [a for a in argv if a not in ("--quiet",)]
        for option in ("--workers", "--shard", "--limit", "--params"):
            forwarded = _drop_option(forwarded, option)
        forwarded += ["--shard", f"{shard[0]}/{shard[1]}", "--params", ",".join(job.spec.modelled)]
        with terminate_as_exit():  # a `kill` stops the workers too (run_workers' finally)
            made = run_workers(job, indices, args.workers, _launcher() + ["dataset", *forwarded],
                               args.restart_every, args.quiet)
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
