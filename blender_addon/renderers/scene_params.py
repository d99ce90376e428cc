"""`vto scene-params`: which inputs of a face layer's group (VTO Lipstick's by default) visibly change a user's scene
(model only what it requires)."""

from __future__ import annotations

import json

import bpy

from vto_core.cli import ArgumentParser
from vto_core.errors import VtoError
from vto_core.products import PRODUCTS
from vto_core.visibility import VISIBLE_RATIO, parameter_visibility, quartile_values

from ..blendfile import open_blend
from .products import blender_side
from .node_utils import material_name


# The products whose groups a user's scene may hold (their kind's user_scenes), the first the default.
SCENE_PRODUCTS = [p.name for p in PRODUCTS.values() if p.kind.user_scenes]


def user_scene(material: str | None = None, product: str = SCENE_PRODUCTS[0]) -> bpy.types.Scene:
    """The open file's active scene, checked to use `product`'s group (in `material`, when named).

    Values are written to every group node of the scene alike; `material` only names which one must be there.
    """
    side = blender_side(product)
    scene = bpy.context.scene
    nodes = side.scene_nodes(scene) if scene is not None else []
    if material is not None:
        nodes = [n for n in nodes if material_name(n) == material]
    if not nodes:
        where = f"material '{material}'" if material else "any material of its active scene"
        raise VtoError(f"{bpy.data.filepath or 'the open file'}: {where} does not use the "
                       f"'{side.layer_group.name}' node group")
    return scene


def visible_parameters(scene: bpy.types.Scene, res: int | None = None, samples: int | None = None,
                       product: str = SCENE_PRODUCTS[0]) -> list[dict]:
    """For each input of `product`'s group: its 25th -> 75th percentile change on `scene` against render noise.

    Other inputs stay at the scene's own values; the scene's values are put back afterwards. Linked inputs are
    reported, not measured. Returns one dict per input: name, socket, ratio (or None), visible, reason.
    """
    side = blender_side(product)
    own = side.scene_values(scene)
    linked = set(side.linked_inputs(scene))
    rows = []
    try:
        for param in side.product.spec.params:
            if param.name in linked:
                rows.append({"name": param.name, "socket": param.socket, "ratio": None, "visible": False,
                             "reason": "driven by a link in the material"})
                continue
            ratio = parameter_visibility(
                lambda values, seed: side.render_scene(values, res=res, samples=samples, seed=seed, scene=scene),
                param, own)  # every render writes all own values: no measured input stays moved for the next
            low, high = quartile_values(param)
            visible = ratio >= VISIBLE_RATIO
            rows.append({"name": param.name, "socket": param.socket, "ratio": round(ratio, 3), "visible": visible,
                         "reason": f"{low:g} -> {high:g} changes the image {ratio:.2f}x the render noise"
                                   + ("" if visible else f" (< {VISIBLE_RATIO:g})")})
    finally:
        side.set_values(scene, own, fill_defaults=False)
    return rows


def cmd_scene_params(argv: list[str]) -> int:
    """vto scene-params [--product NAME] [--blend FILE] [--material NAME] [--res R] [--samples N]."""
    parser = ArgumentParser(prog="vto scene-params",
                            description="list which inputs of a product's group visibly change a user's scene")
    parser.add_argument("--product", default=SCENE_PRODUCTS[0], choices=SCENE_PRODUCTS,
                        help=f"whose group (default {SCENE_PRODUCTS[0]})")
    parser.add_argument("--blend", default=None, help="the .blend (default: the file open in Blender)")
    parser.add_argument("--material", default=None, help="only this material's group")
    parser.add_argument("--res", type=int, default=None, help="override the scene's resolution (square)")
    parser.add_argument("--samples", type=int, default=None, help="override the scene's Cycles samples")
    args = parser.parse_args(argv)
    open_blend(args.blend)
    rows = visible_parameters(user_scene(args.material, args.product), args.res, args.samples, args.product)
    for row in rows:
        print(json.dumps(row))
    visible = [row["name"] for row in rows if row["visible"]]
    print(json.dumps({"visible": visible, "hidden": [row["name"] for row in rows if not row["visible"]],
                      "params": ",".join(visible)}))
    return 0
