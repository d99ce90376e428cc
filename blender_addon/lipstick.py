"""Render API of the lipstick renderer R(X, g): the default lips scene with the "VTO Lipstick" group."""

from __future__ import annotations

import bpy
import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.specs import get_spec

from .nodes_lipstick import GROUP_NAME
from .render import configure_cycles, render_passes, to_display
from .scene_lips import apply_source, build_lips_scene


def makeup_nodes(scene: bpy.types.Scene) -> list[bpy.types.Node]:
    """Every "VTO Lipstick" group node in the materials of `scene`'s objects."""
    found = []
    materials = {slot.material for obj in scene.objects for slot in obj.material_slots if slot.material}
    for material in materials:
        if material.use_nodes:
            found += [n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeGroup"
                      and n.node_tree is not None and n.node_tree.name.startswith(GROUP_NAME)]
    return found


def set_lipstick_values(scene: bpy.types.Scene, values: dict[str, float]) -> dict[str, float]:
    """Set all 17 inputs (unnamed ones to defaults) on every makeup node of `scene`; returns what was set."""
    spec = get_spec("lipstick")
    full = spec.full_values(values)
    nodes = makeup_nodes(scene)
    if not nodes:
        raise VtoError(f"scene '{scene.name}' has no material using the '{GROUP_NAME}' node group")
    for node in nodes:
        for param in spec.params:
            node.inputs[param.socket].default_value = full[param.name]
    return full


def render_lipstick(values: dict[str, float], source: int = 0, res: int = 64, samples: int = DEFAULT_SAMPLES,
                    seed: int = 0, scene: bpy.types.Scene | None = None) -> np.ndarray:
    """R(X, g): display-sRGB image (res, res, 3) float32 of the lips `source` wearing `values`.

    With `scene` given (a user's scene using the group) that scene is rendered and `source` is ignored.
    """
    if scene is None:
        scene = build_lips_scene()
        if scene.get("vto_source_seed") != int(source):
            apply_source(scene, int(source))
    set_lipstick_values(scene, values)
    configure_cycles(scene, res, samples, seed)
    return to_display(render_passes(scene)["Combined"][..., :3])
