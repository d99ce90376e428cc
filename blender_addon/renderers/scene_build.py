"""What a face layer's default scene is built from (blender_addon.renderers.face_layer): meshes, skin tones, its light
(wide or portrait, lighting.py), its camera, the source it shows, and the region's mask from the object-index pass."""

from __future__ import annotations

from collections.abc import Callable

import bpy
import numpy as np

from vto_core.errors import VtoError

from .lighting import LIGHTINGS, build_hdri_world, randomise_hdri, randomise_portrait

# sRGB 8-bit tones, light to dark.
SKIN_TONES = [(241, 194, 167), (224, 172, 138), (198, 146, 110), (161, 110, 75), (118, 78, 52), (80, 52, 36)]
DEFAULT_LIGHTING = "portrait"
REGION_PASS_INDEX = 1  # the region's object index: the IndexOB pass of a render is the region's mask


def get_or_create_scene(name: str, build: Callable[[bpy.types.Scene], None]) -> bpy.types.Scene:
    """The scene `name`, built by `build` (given the new, empty scene) the first time it is asked for."""
    scene = bpy.data.scenes.get(name)
    if scene is None:
        scene = bpy.data.scenes.new(name)
        build(scene)
    return scene


def grid_faces(columns: int, rows: int, offset: int = 0, keep=None) -> list[tuple[int, int, int, int]]:
    """Quads of a (rows + 1) x (columns + 1) vertex grid, row-major from `offset`; keep(r, c) filters them."""
    width = columns + 1
    return [(offset + r * width + c, offset + r * width + c + 1, offset + (r + 1) * width + c + 1,
             offset + (r + 1) * width + c)
            for r in range(rows) for c in range(columns) if keep is None or keep(r, c)]


def mesh_object(scene, name: str, vertices: np.ndarray, faces, material) -> bpy.types.Object:
    """A new smooth-shaded mesh object in `scene` with `vertices` (..., 3), `faces` and `material`."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.reshape(-1, 3).tolist(), [], faces)
    mesh.materials.append(material)
    mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def uv_sphere(segments: int, rings: int, radius: float) -> tuple[list, list, list]:
    """(vertices, edges, faces) of a UV sphere about z, in a fixed order.

    bmesh's create_uvsphere orders its faces differently from run to run, and with them Blender's normals and
    Cycles' sums, so renders changed in the last bit between runs.
    """
    polar = np.pi * np.arange(1, rings) / rings
    azimuth = 2 * np.pi * np.arange(segments) / segments
    ring = np.stack([np.outer(np.sin(polar), np.cos(azimuth)), np.outer(np.sin(polar), np.sin(azimuth)),
                     np.repeat(np.cos(polar)[:, None], segments, 1)], -1).reshape(-1, 3)
    vertices = np.concatenate([[(0.0, 0.0, 1.0)], ring, [(0.0, 0.0, -1.0)]]) * radius
    bottom = len(vertices) - 1

    def at(k, j):  # vertex j of ring k (0 = nearest the top)
        return 1 + k * segments + j % segments

    faces = [(0, at(0, j), at(0, j + 1)) for j in range(segments)]
    faces += [(at(k, j), at(k + 1, j), at(k + 1, j + 1), at(k, j + 1))
              for k in range(rings - 2) for j in range(segments)]
    faces += [(bottom, at(rings - 2, j + 1), at(rings - 2, j)) for j in range(segments)]
    return vertices.tolist(), [], faces


def finish_scene(scene: bpy.types.Scene, camera_name: str, lens: float, sensor: float | None,
                 apply_source: Callable) -> bpy.types.Scene:
    """Give a default scene its camera, the object-index pass (the region's mask), its world and source 0; returns
    it."""
    camera = bpy.data.objects.new(camera_name, bpy.data.cameras.new(camera_name))
    camera.data.lens = lens
    if sensor is not None:
        camera.data.sensor_width = sensor
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.view_layers[0].use_pass_object_index = True
    build_hdri_world(scene)
    apply_source(scene, 0)
    return scene


def randomise_light(scene: bpy.types.Scene, rng: np.random.Generator) -> None:
    """Draw the scene's light from `rng` the scene's way (portrait or wide)."""
    if scene.get("vto_lighting", DEFAULT_LIGHTING) == "portrait":
        randomise_portrait(scene, rng)
    else:
        randomise_hdri(scene, rng, (0.6, 1.6))


def use_lighting(scene: bpy.types.Scene, lighting: str | None = None) -> None:
    """Light a default scene's sources the `lighting` way from now on ("wide" or "portrait", lighting.py; None:
    DEFAULT_LIGHTING)."""
    lighting = lighting or DEFAULT_LIGHTING
    if lighting not in LIGHTINGS:
        raise VtoError(f"lighting is {' or '.join(LIGHTINGS)}, got '{lighting}'")
    if scene.get("vto_lighting", DEFAULT_LIGHTING) != lighting:
        scene["vto_lighting"] = lighting
        scene.pop("vto_source_seed", None)  # the next render applies its source again, lit the new way


def tones_key(tones: tuple[np.ndarray, np.ndarray] | None) -> list[float]:
    """What the scene records of the tones a source was applied with ([] for the seed's own)."""
    return [] if tones is None else [round(float(v), 6) for t in tones for v in t]


def record_source(scene: bpy.types.Scene, source_seed: int, tones=None, light_seed: int | None = None) -> None:
    """Note on `scene` the source it now shows (what `applied` reads)."""
    scene["vto_source_seed"] = int(source_seed)
    scene["vto_source_tones"] = tones_key(tones)
    scene["vto_light_seed"] = -1 if light_seed is None else int(light_seed)


def applied(scene: bpy.types.Scene, source_seed: int, tones: tuple[np.ndarray, np.ndarray] | None = None,
            light_seed: int | None = None) -> bool:
    """Whether `scene` shows `source_seed` with `tones` and `light_seed` already (apply_source would change nothing)."""
    return (scene.get("vto_source_seed") == int(source_seed)
            and list(scene.get("vto_source_tones", [])) == tones_key(tones)
            and scene.get("vto_light_seed", -1) == (-1 if light_seed is None else int(light_seed)))


def region_mask(build: Callable[[], bpy.types.Scene], apply_source: Callable, source_seed: int, res: int,
                lighting: str | None = None) -> np.ndarray:
    """Where the region is in a res x res render of the default scene `build` gives with `source_seed`, lit the
    `lighting` way (the camera's jitter is drawn after the light): (res, res) bool."""
    from .cycles import configure_cycles, render_passes

    scene = build()
    use_lighting(scene, lighting)
    if scene.get("vto_source_seed") != int(source_seed):
        apply_source(scene, int(source_seed))
    configure_cycles(scene, res, 1, 0)
    scene.cycles.use_denoising = False
    return np.abs(render_passes(scene)["IndexOB"][..., 0] - REGION_PASS_INDEX) < 0.5
