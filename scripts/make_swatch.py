"""Render the reference hair swatch shipped in blender_addon/data (run once; the PNG is committed)."""

import math
import sys

import numpy as np

from blender_addon.renderers.hair import SWATCH_PATH, render_hair_source
from blender_addon.renderers.scene_hair import HAIR_MATERIAL, build_hair_scene
from vto_core.imageio import write_image


def main(size: int = 96) -> None:
    """Close-up of the back of the default head, mid-brown hair, cropped to hair only."""
    import bpy

    scene = build_hair_scene()
    render_hair_source(0, 8, 1)  # settle source 0, then override colour and camera
    nodes = bpy.data.materials[HAIR_MATERIAL].node_tree.nodes["Hair BSDF"]
    nodes.inputs["Melanin"].default_value = 0.55
    nodes.inputs["Melanin Redness"].default_value = 0.45
    scene.camera.location = (0.0, 2.6, -0.2)
    scene.camera.rotation_euler = (math.radians(90), 0.0, math.radians(180))
    source = render_hair_source(0, 2 * size, 64)
    rows, cols = np.nonzero(source.mask > 0.5)
    top, left = rows.min() + (rows.max() - rows.min() - size) // 2, cols.min() + (cols.max() - cols.min() - size) // 2
    crop = source.rgb[top:top + size, left:left + size]
    if source.mask[top:top + size, left:left + size].mean() < 0.95:
        sys.exit("the swatch crop is not all hair")
    write_image(SWATCH_PATH, crop)
    print(f"wrote {SWATCH_PATH} ({size}x{size})")


if __name__ == "__main__":
    main()
