"""Image-based lighting shared by the default scenes: Blender's bundled HDRIs, rotated and scaled by a seed."""

from __future__ import annotations

import math
import os

import bpy
import numpy as np

HDRI_WIDTH = 256  # 0.07 s per 64 px render instead of 1.1 s at full size (importance map rebuilt each render)


def hdri_paths() -> list[str]:
    """Blender's bundled studio-light HDRIs (CC0), sorted so a seed picks the same file everywhere."""
    folder = os.path.join(bpy.utils.system_resource("DATAFILES"), "studiolights", "world")
    return sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.endswith(".exr"))


def load_hdri(path: str) -> bpy.types.Image:
    """Load an HDRI once, downscaled: at small render sizes the full map only costs importance-map time."""
    name = "VTO HDRI " + os.path.basename(path)
    image = bpy.data.images.get(name)
    if image is not None:
        return image
    image = bpy.data.images.load(path)
    image.name = name
    if image.size[0] > HDRI_WIDTH:
        image.scale(HDRI_WIDTH, HDRI_WIDTH // 2)
    return image


def build_hdri_world(scene: bpy.types.Scene) -> None:
    """Give `scene` a world of its own: environment texture behind a z-rotation, importance-sampled."""
    world = bpy.data.worlds.new(scene.name)
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    mapping = nodes.new("ShaderNodeMapping")
    mapping.name = "HDRI Rotation"
    environment = nodes.new("ShaderNodeTexEnvironment")
    environment.name = "HDRI"
    environment.image = load_hdri(hdri_paths()[0])
    links.new(nodes.new("ShaderNodeTexCoord").outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs[0], environment.inputs["Vector"])
    links.new(environment.outputs[0], nodes["Background"].inputs["Color"])
    world.cycles.sampling_method = "MANUAL"
    world.cycles.sample_map_resolution = HDRI_WIDTH // 2
    scene.world = world


def randomise_hdri(scene: bpy.types.Scene, rng: np.random.Generator, strength: tuple[float, float]) -> None:
    """Pick an HDRI, a rotation about z and a strength in `strength` for `scene`'s world, in place."""
    nodes = scene.world.node_tree.nodes
    paths = hdri_paths()
    nodes["HDRI"].image = load_hdri(paths[rng.integers(len(paths))])
    nodes["HDRI Rotation"].inputs["Rotation"].default_value = (0.0, 0.0, rng.uniform(0, 2 * math.pi))
    nodes["Background"].inputs["Strength"].default_value = rng.uniform(*strength)
