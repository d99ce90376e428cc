"""Render API of the lipstick renderer R(X, g): the default lips scene with the "VTO Lipstick" group."""

from __future__ import annotations

import bpy
import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.products import get_spec

from ..compat import uses_nodes
from .node_utils import node_values
from .nodes_lipstick import GROUP_NAME
from .cycles import configure_cycles, render_passes, render_user_scene, to_display
from .scene_lips import applied, apply_source, build_lips_scene, use_lighting


def material_nodes(material) -> list[bpy.types.Node]:
    """The "VTO Lipstick" group nodes of `material` (none when it is None or has no node tree)."""
    if material is None or not uses_nodes(material) or material.node_tree is None:
        return []
    return [n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
            and n.node_tree.name.startswith(GROUP_NAME)]


def makeup_nodes(scene: bpy.types.Scene) -> list[bpy.types.Node]:
    """Every "VTO Lipstick" group node in the materials of `scene`'s objects."""
    materials = {slot.material for obj in scene.objects for slot in obj.material_slots if slot.material}
    return [node for material in materials for node in material_nodes(material)]


def material_name(node: bpy.types.Node) -> str:
    """The name of the material whose node tree holds `node`."""
    return next((m.name for m in bpy.data.materials if m.node_tree == node.id_data), node.id_data.name)


def set_lipstick_values(scene: bpy.types.Scene, values: dict[str, float], fill_defaults: bool = True) -> dict[str, float]:
    """Set the group inputs on every makeup node of `scene`; returns the values written.

    fill_defaults: the default scene gets all 17 inputs (unnamed ones at their defaults); a user's scene gets only
    `values`, its other inputs keep the artist's settings. An input driven by a link cannot take a value: that is
    an error naming it, raised before anything is written.
    """
    spec = get_spec("lipstick")
    full = spec.full_values(values)  # checked and clamped
    chosen = full if fill_defaults else {name: full[name] for name in values}
    nodes = makeup_nodes(scene)
    if not nodes:
        raise VtoError(f"scene '{scene.name}' has no material using the '{GROUP_NAME}' node group")
    for node in nodes:
        for name in chosen:
            socket = node.inputs[spec.by_name[name].socket]
            if socket.is_linked:
                raise VtoError(f"input '{socket.name}' of node '{node.name}' in material '{material_name(node)}' is "
                               f"driven by a link, so it cannot take the {name} value; unlink it or leave {name} "
                               "unmodelled")
    for node in nodes:
        for name, value in chosen.items():
            node.inputs[spec.by_name[name].socket].default_value = value
    return chosen


def scene_values(scene: bpy.types.Scene) -> dict[str, float]:
    """The lipstick group inputs of the first makeup node of `scene` as the artist set them (linked ones left out)."""
    nodes = makeup_nodes(scene)
    if not nodes:
        raise VtoError(f"scene '{scene.name}' has no material using the '{GROUP_NAME}' node group")
    return node_values(nodes[0], get_spec("lipstick"))




def linked_inputs(scene: bpy.types.Scene) -> list[str]:
    """Names of the lipstick parameters whose input is driven by a link on any makeup node of `scene`."""
    return [p.name for p in get_spec("lipstick").params
            if any(node.inputs[p.socket].is_linked for node in makeup_nodes(scene))]


def render_lipstick(values: dict[str, float], source: int = 0, res: int | None = 64,
                    samples: int | None = DEFAULT_SAMPLES, seed: int = 0,
                    scene: bpy.types.Scene | None = None, lighting: str | None = None,
                    tones: tuple[np.ndarray, np.ndarray] | None = None, light_seed: int | None = None) -> np.ndarray:
    """R(X, g): display-sRGB image (res, res, 3) float32 of the lips `source`, lit the `lighting` way (None: the
    default), wearing `values`; `tones` (sRGB (3,) of the skin and the bare lips) replace the source's own, and the
    light of source `light_seed` the source's own light where given.

    With `scene` given (a user's scene using the group) that scene is rendered with its own settings, only `values`
    and the res/samples given (not None) changing it; `source` is ignored.
    """
    if scene is not None:
        set_lipstick_values(scene, values, fill_defaults=False)
        return render_user_scene(scene, res, samples, seed)
    scene = build_lips_scene()
    use_lighting(scene, lighting)
    if not applied(scene, source, tones, light_seed):
        apply_source(scene, int(source), tones, light_seed)
    set_lipstick_values(scene, values)
    configure_cycles(scene, res, samples, seed)
    return to_display(render_passes(scene)["Combined"][..., :3])
