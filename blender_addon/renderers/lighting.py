"""Image-based lighting shared by the default scenes: Blender's bundled HDRIs, rotated and scaled by a seed.

Two kinds: "wide" (any of the 8 maps at any rotation about the vertical and strength 0.6-1.6) and "portrait" (a
neutral map turned so its key light is in front of the face, white-balanced and metered on the face;
vto_core.portrait_light).

Each HDRI is split (vto_core.envlight) into a low-contrast residual map and up to ENV_LIGHTS sun lamps that
carry its bright spots: the same light, sampled directly instead of found by chance, so renders are far
less noisy for the same samples.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os

import bpy
import numpy as np

from vto_core.envlight import DistantLight, split_environment
from vto_core.portrait_light import portrait_light

from ..compat import enable_nodes

HDRI_WIDTH = 256  # 0.07 s per 64 px render instead of 1.1 s at full size (importance map rebuilt each render)
ENV_LIGHTS = 4
SUN_PREFIX = "VTO Env Light "
LIGHTINGS = ("wide", "portrait")
ONLY_LIPS = ("--lighting chooses the default lips and eye scenes' light; the hair scene and a user's scene keep "
             "their own")
PORTRAIT_HDRIS = ("city.exr", "interior.exr", "studio.exr")  # the neutral maps with a clear key light


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
def _split(path: str) -> tuple[str, tuple[DistantLight, ...], np.ndarray]:
    """Load an HDRI once, downscaled, and split it: (name of the residual image, its lights, the residual (H, W, 3))."""
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
    return name, tuple(lights), residual


def load_hdri(path: str) -> bpy.types.Image:
    """The residual map of an HDRI (its bright spots lifted out into lights), made once per session."""
    name, _, _ = _split(path)
    image = bpy.data.images.get(name)
    if image is None:  # the .blend was reloaded: make it again
        _split.cache_clear()
        name, _, _ = _split(path)
        image = bpy.data.images[name]
    return image


def build_hdri_world(scene: bpy.types.Scene) -> None:
    """Give `scene` a world of its own (environment texture behind a z-rotation) and its env-light suns."""
    world = bpy.data.worlds.new(scene.name)
    enable_nodes(world)
    nodes, links = world.node_tree.nodes, world.node_tree.links
    mapping = nodes.new("ShaderNodeMapping")
    mapping.name = "HDRI Rotation"
    environment = nodes.new("ShaderNodeTexEnvironment")
    environment.name = "HDRI"
    environment.image = load_hdri(hdri_paths()[0])
    tint = nodes.new("ShaderNodeVectorMath")  # portrait lighting's white balance; (1, 1, 1) for wide
    tint.name, tint.operation = "HDRI Tint", "MULTIPLY"
    tint.inputs[1].default_value = (1.0, 1.0, 1.0)
    links.new(nodes.new("ShaderNodeTexCoord").outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs[0], environment.inputs["Vector"])
    links.new(environment.outputs[0], tint.inputs[0])
    links.new(tint.outputs[0], nodes["Background"].inputs["Color"])
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
    """Wide lighting: an HDRI, a rotation about z and a strength in `strength` for `scene`'s world and suns."""
    nodes = scene.world.node_tree.nodes
    paths = hdri_paths()
    path = paths[rng.integers(len(paths))]
    nodes["HDRI"].image = load_hdri(path)
    rotation = rng.uniform(0, 2 * math.pi)
    scale = rng.uniform(*strength)
    nodes["HDRI Rotation"].inputs["Rotation"].default_value = (0.0, 0.0, rotation)
    nodes["Background"].inputs["Strength"].default_value = scale
    nodes["HDRI Tint"].inputs[1].default_value = (1.0, 1.0, 1.0)
    _, lights, _ = _split(path)
    # The mapping looks the map up at Rz(rotation) d, so a spot at map direction e shines from Rz(-rotation) e.
    cos, sin = math.cos(-rotation), math.sin(-rotation)
    turned = [np.array([cos * x - sin * y, sin * x + cos * y, z]) for x, y, z in (light.direction for light in lights)]
    _set_suns(scene, [(d, light.irradiance, light.angle) for d, light in zip(turned, lights)], scale)


def randomise_portrait(scene: bpy.types.Scene, rng: np.random.Generator) -> None:
    """Portrait lighting: a neutral HDRI turned so its key light is in front of the face (+z), white-balanced and
    metered on the face (vto_core.portrait_light), for `scene`'s world and suns."""
    from mathutils import Matrix

    nodes = scene.world.node_tree.nodes
    paths = [path for path in hdri_paths() if os.path.basename(path) in PORTRAIT_HDRIS]
    path = paths[rng.integers(len(paths))]
    nodes["HDRI"].image = load_hdri(path)
    _, lights, residual = _split(path)
    light = portrait_light(residual, list(lights), rng)
    nodes["HDRI Rotation"].inputs["Rotation"].default_value = Matrix(light.lookup.tolist()).to_euler("XYZ")
    nodes["Background"].inputs["Strength"].default_value = light.strength * light.fill
    nodes["HDRI Tint"].inputs[1].default_value = tuple(light.tint)
    _set_suns(scene, [(light.rotation @ spot.direction, light.tint * spot.irradiance, spot.angle) for spot in lights],
              light.strength)


def _set_suns(scene: bpy.types.Scene, suns: list[tuple[np.ndarray, np.ndarray, float]], scale: float) -> None:
    """Point the scene's env-light suns: (world direction towards the light (3,), RGB irradiance (3,), angle) each,
    the irradiance times `scale`; the suns left over are off."""
    for index in range(ENV_LIGHTS):
        sun_object = scene.objects[f"{SUN_PREFIX}{scene.name} {index}"]
        sun = sun_object.data
        if index >= len(suns):
            sun.energy = 0.0
            continue
        direction, rgb, angle = suns[index]
        peak = float(rgb.max())
        sun.energy = scale * peak
        sun.color = tuple(rgb / peak)
        sun.angle = max(angle, 1e-3)
        sun_object.rotation_mode = "QUATERNION"
        sun_object.rotation_quaternion = _track(direction)


def _track(direction: np.ndarray) -> tuple[float, float, float, float]:
    """Quaternion turning a sun's +z axis onto `direction` (a sun shines along its -z)."""
    from mathutils import Vector

    return tuple(Vector(direction.tolist()).to_track_quat("Z", "Y"))


@contextlib.contextmanager
def turned_light(scene: bpy.types.Scene, turn: np.ndarray, fill: float = 1.0):
    """Renders inside see `scene`'s light (its map and its suns) turned by `turn` (3, 3; world directions to world
    directions) and its map's strength times `fill`; put back after. What the render floor moves of a source's light
    (benchmarks/bench_render_floor.py)."""
    from mathutils import Euler, Matrix

    nodes = scene.world.node_tree.nodes
    rotation, strength = nodes["HDRI Rotation"].inputs["Rotation"], nodes["Background"].inputs["Strength"]
    suns = [scene.objects[f"{SUN_PREFIX}{scene.name} {index}"] for index in range(ENV_LIGHTS)]
    kept = (tuple(rotation.default_value), strength.default_value,
            [(sun.rotation_mode, tuple(sun.rotation_quaternion), tuple(sun.rotation_euler)) for sun in suns])
    # The mapping looks the map up at L d; turned, a world direction d sees what turn^T d saw: L turn^T.
    lookup = np.array(Euler(kept[0], "XYZ").to_matrix())
    rotation.default_value = Matrix((lookup @ np.asarray(turn).T).tolist()).to_euler("XYZ")
    strength.default_value = kept[1] * fill
    quaternion = Matrix(np.asarray(turn).tolist()).to_quaternion()
    for sun in suns:
        sun.rotation_mode = "QUATERNION"
        sun.rotation_quaternion = quaternion @ sun.rotation_quaternion
    try:
        yield
    finally:
        rotation.default_value, strength.default_value = kept[0], kept[1]
        for sun, (mode, turned, euler) in zip(suns, kept[2]):
            sun.rotation_quaternion, sun.rotation_euler, sun.rotation_mode = turned, euler, mode
