"""The `vto` command: one dispatcher for the console script and for `blender -c vto`."""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import warnings

from .errors import VtoError
from .products import PRODUCTS, product_list


def products_that(ability: str, can: bool = True) -> str:
    """The declared products whose kind can (or, with can=False, cannot) `ability` (a Kind field: "tryon",
    "lightings", ...), as a help text lists them: "lipstick or eyeshadow"; "no product" where none."""
    products = [p for p in PRODUCTS.values() if bool(getattr(p.kind, ability)) is can]
    return product_list(products) if products else "no product"


# command -> (module, function, one-line help). Modules load lazily so `vto spec`
# needs neither bpy nor torch. Modules under ADDON_PACKAGE are the add-on's: run() looks them up in the
# package its caller names (the extension's own package inside Blender, see blender_addon.run_cli).
# The layers: vto_core (here) < blender_addon (bpy), training (torch) < pipeline (both); see README "Layout".
ADDON_PACKAGE = "blender_addon"
COMMANDS = {
    "spec": ("vto_core.cli", "cmd_spec", "print a renderer's (selected) parameter spec as JSON"),
    "sample": ("vto_core.cli", "cmd_sample", "print sampled parameter vectors as JSON lines"),
    "presets": ("vto_core.cli", "cmd_presets", "list a renderer's expert presets"),
    "render": ("blender_addon.renderers.commands", "cmd_render", "render one image with Blender (needs bpy)"),
    "dataset": ("blender_addon.datasets.commands", "cmd_dataset",
                "render a training dataset, sharded and resumable (needs bpy)"),
    "train": ("training.cli", "cmd_train", "train the imitator or the encoder (needs torch)"),
    "export": ("training.cli", "cmd_export", "export an encoder run to ONNX"),
    "scene-params": ("blender_addon.renderers.scene_params", "cmd_scene_params",
                     f"list which inputs of a product's group ({products_that('user_scenes')}) visibly change a "
                     "user's scene (needs bpy)"),
    "tryon": ("blender_addon.renderers.commands", "cmd_tryon",
              f"draw a product ({products_that('tryon')}) onto a portrait (needs bpy)"),
    "match": ("pipeline.match", "cmd_match", "estimate a renderer's parameters from a reference image"),
    "find-face": ("blender_addon.matching.commands", "cmd_find_face",
                  "find the face on a character's head mesh and write its regions for the makeup layers (needs bpy)"),
    "batch": ("blender_addon.matching.batch", "cmd_batch",
              "estimate a folder of product photos: median presets, an asset library, a contact sheet"),
    "eval": ("pipeline.cli", "cmd_eval", "the paper's transfer experiment on an exported encoder (needs bpy)"),
    "demo": ("pipeline.demo", "cmd_demo", "the whole pipeline on the default scene: data, imitator, encoder, ONNX, "
                                          "evaluation, HTML report (needs bpy and torch)"),
}
# Pipeline commands the add-on serves itself inside Blender, where the pipeline and training layers are absent.
IN_BLENDER = {"match": ("blender_addon.matching.commands", "cmd_match")}


class ArgumentParser(argparse.ArgumentParser):
    """argparse whose usage errors are VtoErrors, so every bad input ends as one line and exit status 2."""

    def error(self, message):
        raise VtoError(message)


def add_spec_args(parser: argparse.ArgumentParser) -> None:
    """The renderer and --params arguments every spec-using command shares."""
    from .products import product_names

    parser.add_argument("renderer", choices=product_names())
    parser.add_argument("--params", default=None, help="comma-separated subset of parameters to model")


def cmd_spec(argv: list[str]) -> int:
    """vto spec RENDERER [--params a,b]."""
    from .products import get_spec

    parser = ArgumentParser(prog="vto spec", description=COMMANDS["spec"][2])
    add_spec_args(parser)
    args = parser.parse_args(argv)
    spec = get_spec(args.renderer, args.params)
    out = spec.to_dict()
    out["vector_order"] = list(spec.modelled)
    out["left_out"] = spec.left_out()
    print(json.dumps(out, indent=1))
    return 0


def cmd_sample(argv: list[str]) -> int:
    """vto sample RENDERER --n N --seed S [--params a,b] [--uniform-ratio R]."""
    from .presets import load_presets, preset_matrix
    from .sampling import ParamSampler
    from .products import get_spec

    parser = ArgumentParser(prog="vto sample", description=COMMANDS["sample"][2])
    add_spec_args(parser)
    parser.add_argument("--n", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--start", type=int, default=0, help="first sample index")
    parser.add_argument("--uniform-ratio", type=float, default=0.5)
    args = parser.parse_args(argv)
    if args.n < 1:
        raise VtoError(f"--n must be at least 1, got {args.n}")
    spec = get_spec(args.renderer, args.params)
    sampler = ParamSampler(spec, preset_matrix(spec, load_presets(args.renderer)), args.uniform_ratio, args.seed)
    for index in range(args.start, args.start + args.n):
        raw = sampler.sample(index)
        print(json.dumps({"index": index, "params": dict(zip(spec.modelled, raw.round(6).tolist()))}))
    return 0


def cmd_presets(argv: list[str]) -> int:
    """vto presets RENDERER."""
    from .presets import load_presets

    from .products import product_names

    parser = ArgumentParser(prog="vto presets", description=COMMANDS["presets"][2])
    parser.add_argument("renderer", choices=product_names())
    args = parser.parse_args(argv)
    for name, values in load_presets(args.renderer).items():
        print(json.dumps({"name": name, "params": values}))
    return 0


def command_module(module: str, addon_package: str = ADDON_PACKAGE) -> str:
    """COMMANDS' module name with the add-on's package replaced by `addon_package` (e.g. "bl_ext.user_default.vto_match")."""
    if module == ADDON_PACKAGE or module.startswith(ADDON_PACKAGE + "."):
        return addon_package + module[len(ADDON_PACKAGE):]
    return module


def run(argv: list[str], addon_package: str = ADDON_PACKAGE) -> int:
    """Dispatch argv (without the program name) to a command; VtoError -> one line, exit 2.

    addon_package: the package holding the add-on's command modules: "blender_addon" for the console script,
    the extension's package name (its __package__) when Blender runs `blender -c vto`.
    """
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: vto COMMAND [args]\n\ncommands:")
        for name, (_, _, text) in COMMANDS.items():
            print(f"  {name:<10} {text}")
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"vto: error: unknown command '{name}'; choose from {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    module, function, _ = COMMANDS[name]
    if addon_package != ADDON_PACKAGE and name in IN_BLENDER:
        module, function = IN_BLENDER[name]
    warnings.simplefilter("default")
    try:
        found = importlib.import_module(command_module(module, addon_package))
    except ModuleNotFoundError as exc:
        missing = (exc.name or "?").split(".")[0]
        print(f"vto {name}: error: needs the module '{missing}', which this Python cannot import (inside Blender "
              "only the add-on's commands and match run; the others need the project's `vto` console script)",
              file=sys.stderr)
        return 2
    try:
        return getattr(found, function)(rest) or 0
    except VtoError as exc:
        print(f"vto {name}: error: {exc}", file=sys.stderr)
        return 2
    except SystemExit as exc:  # --help
        return int(exc.code or 0)
    except KeyboardInterrupt:
        print(f"vto {name}: interrupted", file=sys.stderr)
        return 130


def main() -> None:
    """Console-script entry point."""
    sys.exit(run(sys.argv[1:]))


if __name__ == "__main__":
    main()
