"""Image-based lighting shared by the default scenes: Blender's bundled HDRIs, rotated and scaled by a seed.

Each HDRI is split (vto_core.envlight) into a low-contrast residual map and up to ENV_LIGHTS sun lamps that
carry its bright spots: the same light, sampled directly instead of found by chance, so renders are far
less noisy for the same samples.
"""

from __future__ import annotations

import functools
import math
import os

import bpy
import numpy as np

from vto_core.envlight import DistantLight, split_environment

HDRI_WIDTH = 256  # 0.07 s per 64 px render instead of 1.1 s at full size (importance map rebuilt each render)
ENV_LIGHTS = 4
SUN_PREFIX = "VTO Env Light "


def hdri_paths() -> list[str]:
    """Blender's bundled studio-light HDRIs (CC0), sorted so a seed picks the same file everywhere."""
    folder = os.path.join(bpy.utils.system_resource("DATAFILES"), "studiolights", "world")
    return sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.endswith(".exr"))


def _pixels(image: bpy.types.Image) -> np.ndarray:
    width, height = image.size
    flat = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(flat)
    return flat.reshape(height, width, 4)[..., :3]


@functools.lru_cache(maxsize=None)
def _split(path: str) -> tuple[str, tuple[DistantLight, ...]]:
    """Load an HDRI once, downscaled, and split it: (name of the residual image, its lights)."""
    name = "VTO HDRI " + os.path.basename(path)
    residual_image = bpy.data.images.get(name)
    source = bpy.data.images.load(path)
    if source.size[0] > HDRI_WIDTH:  # at small render sizes the full map only costs importance-map time
        source.scale(HDRI_WIDTH, HDRI_WIDTH // 2)
    residual, lights, _ = split_environment(_pixels(source), ENV_LIGHTS)
    height, width = residual.shape[:2]
    bpy.data.images.remove(source)
    if residual_image is None:
        residual_image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = residual
    residual_image.pixels.foreach_set(rgba.reshape(-1))
    residual_image.pack()  # lives in the .blend, not on disk
    return name, tuple(lights)


def load_hdri(path: str) -> bpy.types.Image:
    """The residual map of an HDRI (its bright spots lifted out into lights), made once per session."""
    name, _ = _split(path)
    image = bpy.data.images.get(name)
    if image is None:  # the .blend was reloaded: make it again
        _split.cache_clear()
        name, _ = _split(path)
        image = bpy.data.images[name]
    return image


def build_hdri_world(scene: bpy.types.Scene) -> None:
    """Give `scene` a world of its own (environment texture behind a z-rotation) and its env-light suns."""
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
    for index in range(ENV_LIGHTS):
        sun = bpy.data.lights.new(f"{SUN_PREFIX}{scene.name} {index}", "SUN")
        sun.energy = 0.0
        obj = bpy.data.objects.new(f"{SUN_PREFIX}{scene.name} {index}", sun)
        obj.visible_camera = False
        scene.collection.objects.link(obj)


def randomise_hdri(scene: bpy.types.Scene, rng: np.random.Generator, strength: tuple[float, float]) -> None:
    """Pick an HDRI, a rotation about z and a strength in `strength` for `scene`'s world and suns, in place."""
    nodes = scene.world.node_tree.nodes
    paths = hdri_paths()
    path = paths[rng.integers(len(paths))]
    nodes["HDRI"].image = load_hdri(path)
    rotation = rng.uniform(0, 2 * math.pi)
    scale = rng.uniform(*strength)
    nodes["HDRI Rotation"].inputs["Rotation"].default_value = (0.0, 0.0, rotation)
    nodes["Background"].inputs["Strength"].default_value = scale
    _, lights = _split(path)
    # The mapping looks the map up at Rz(rotation) d, so a spot at map direction e shines from Rz(-rotation) e.
    cos, sin = math.cos(-rotation), math.sin(-rotation)
    for index in range(ENV_LIGHTS):
        sun_object = scene.objects[f"{SUN_PREFIX}{scene.name} {index}"]
        sun = sun_object.data
        if index >= len(lights):
            sun.energy = 0.0
            continue
        light = lights[index]
        x, y, z = light.direction
        direction = np.array([cos * x - sin * y, sin * x + cos * y, z])
        peak = float(light.irradiance.max())
        sun.energy = scale * peak
        sun.color = tuple(light.irradiance / peak)
        sun.angle = max(light.angle, 1e-3)
        sun_object.rotation_mode = "QUATERNION"
        sun_object.rotation_quaternion = _track(direction)


def _track(direction: np.ndarray) -> tuple[float, float, float, float]:
    """Quaternion turning a sun's +z axis onto `direction` (a sun shines along its -z)."""
    from mathutils import Vector

    return tuple(Vector(direction.tolist()).to_track_quat("Z", "Y"))
