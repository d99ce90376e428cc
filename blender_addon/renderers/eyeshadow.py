"""Render API of the eye-shadow renderer R(X, g): the default eye scene with the "VTO Eye Shadow" group."""

from __future__ import annotations

import bpy
import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.products import get_spec

from .cycles import configure_cycles, render_passes, render_user_scene, to_display
from .node_utils import material_group_nodes, scene_group_nodes, scene_group_values, set_group_values
from .nodes_eyeshadow import GROUP_NAME
from .scene_eyes import apply_source, build_eye_scene
from .scene_lips import use_lighting


def material_nodes(material) -> list[bpy.types.Node]:
    """The "VTO Eye Shadow" group nodes of `material` (none when it is None or has no node tree)."""
    return material_group_nodes(material, GROUP_NAME)


def shadow_nodes(scene: bpy.types.Scene) -> list[bpy.types.Node]:
    """Every "VTO Eye Shadow" group node in the materials of `scene`'s objects."""
    return scene_group_nodes(scene, GROUP_NAME)


def set_eyeshadow_values(scene: bpy.types.Scene, values: dict[str, float], fill_defaults: bool = True
                         ) -> dict[str, float]:
    """Set the group inputs on every eye-shadow node of `scene` (node_utils.set_group_values: the default scene gets
    all 17, a user's scene only `values`); returns the values written."""
    return set_group_values(scene, get_spec("eyeshadow"), GROUP_NAME, values, fill_defaults)


def scene_values(scene: bpy.types.Scene) -> dict[str, float]:
    """The eye-shadow inputs of the first group node of `scene` as the artist set them (linked ones left out)."""
    return scene_group_values(scene, get_spec("eyeshadow"), GROUP_NAME)


def render_eyeshadow(values: dict[str, float], source: int = 0, res: int | None = 64,
                     samples: int | None = DEFAULT_SAMPLES, seed: int = 0,
                     scene: bpy.types.Scene | None = None, lighting: str | None = None) -> np.ndarray:
    """R(X, g): display-sRGB image (res, res, 3) float32 of the eye `source`, lit the `lighting` way (None: the
    default), wearing `values`.

    With `scene` given (a user's scene using the group) that scene is rendered with its own settings, only `values`
    and the res/samples given (not None) changing it; `source` is ignored.
    """
    if scene is not None:
        set_eyeshadow_values(scene, values, fill_defaults=False)
        return render_user_scene(scene, res, samples, seed)
    scene = build_eye_scene()
    use_lighting(scene, lighting)
    if scene.get("vto_source_seed") != int(source):
        apply_source(scene, int(source))
    set_eyeshadow_values(scene, values)
    configure_cycles(scene, res, samples, seed)
    return to_display(render_passes(scene)["Combined"][..., :3])
