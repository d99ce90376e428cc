"""Render API of the lipstick renderer R(X, g): the default lips scene with the "VTO Lipstick" group."""

from __future__ import annotations

import bpy
import numpy as np

from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.products import get_spec

from .node_utils import material_group_nodes, scene_group_nodes, scene_group_values, set_group_values
from .nodes_lipstick import GROUP_NAME
from .cycles import configure_cycles, render_passes, render_user_scene, to_display
from .scene_lips import applied, apply_source, build_lips_scene, use_lighting


def material_nodes(material) -> list[bpy.types.Node]:
    """The "VTO Lipstick" group nodes of `material` (none when it is None or has no node tree)."""
    return material_group_nodes(material, GROUP_NAME)


def makeup_nodes(scene: bpy.types.Scene) -> list[bpy.types.Node]:
    """Every "VTO Lipstick" group node in the materials of `scene`'s objects."""
    return scene_group_nodes(scene, GROUP_NAME)


def set_lipstick_values(scene: bpy.types.Scene, values: dict[str, float], fill_defaults: bool = True) -> dict[str, float]:
    """Set the group inputs on every makeup node of `scene` (node_utils.set_group_values: the default scene gets all
    17, a user's scene only `values`); returns the values written."""
    return set_group_values(scene, get_spec("lipstick"), GROUP_NAME, values, fill_defaults)


def scene_values(scene: bpy.types.Scene) -> dict[str, float]:
    """The lipstick group inputs of the first makeup node of `scene` as the artist set them (linked ones left out)."""
    return scene_group_values(scene, get_spec("lipstick"), GROUP_NAME)


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
