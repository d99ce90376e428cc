"""The default lips scene: procedural lips on skin, HDRI light and camera jitter, all set by a source seed.

The scene is built once; `apply_source` then changes vertex positions, colours and the world in place,
so that a long dataset run creates no data blocks per sample.
"""

from __future__ import annotations


import bpy
import numpy as np

from vto_core.colour import srgb_to_linear
from ..compat import enable_nodes
from .nodes_lipstick import lipstick_material
from .scene_build import (REGION_PASS_INDEX, SKIN_TONES, finish_scene, get_or_create_scene, grid_faces, mesh_object,
                          randomise_light, record_source, region_mask)

SCENE_NAME = "VTO Lips"
LIPS_OBJECT = "VTO Lips"
SKIN_OBJECT = "VTO Skin"
LIPS_MATERIAL = "VTO Lips Material"
SKIN_MATERIAL = "VTO Skin Material"
LIPS_PASS_INDEX = REGION_PASS_INDEX  # the lips' object index: the IndexOB pass of a render is the lips mask

LIP_COLUMNS, LIP_ROWS = 48, 12  # per lip: across the mouth, outer contour -> mouth line
SKIN_COLUMNS, SKIN_ROWS = 80, 60
SKIN_HALF_WIDTH, SKIN_HALF_HEIGHT = 2.2, 1.6
MOUTH_DEPTH = 0.35

LIP_TONE_SHIFT = (-0.06, -0.22, -0.18)  # lips: a redder, darker version of the skin tone
LIP_SHIFT_RANGE = (0.6, 1.3)  # how much of LIP_TONE_SHIFT a source's bare lips take


def lip_shape(rng: np.random.Generator) -> dict[str, float]:
    """Random shape parameters of one mouth."""
    return {
        "upper": rng.uniform(0.22, 0.42),
        "lower": rng.uniform(0.28, 0.52),
        "bow": rng.uniform(0.0, 0.1),
        "gap": rng.uniform(0.0, 0.1),
        "smile": rng.uniform(-0.08, 0.12),
        "fullness": rng.uniform(0.08, 0.2),
        "wrap": rng.uniform(0.15, 0.4),
    }


def _contours(u: np.ndarray, shape: dict[str, float]) -> tuple[np.ndarray, ...]:
    """Outer and inner contours of both lips at u in [-1, 1]: (upper_out, upper_in, lower_in, lower_out)."""
    taper = np.clip(1.0 - u**2, 0.0, 1.0)
    curve = shape["smile"] * u**2
    bow = shape["bow"] * np.exp(-((u / 0.14) ** 2)) * taper
    upper_in = 0.5 * shape["gap"] * taper + curve
    lower_in = -0.5 * shape["gap"] * taper + curve
    upper_out = upper_in + shape["upper"] * taper**0.6 - bow
    lower_out = lower_in - shape["lower"] * taper**0.55
    return upper_out, upper_in, lower_in, lower_out


def lip_vertices(shape: dict[str, float]) -> np.ndarray:
    """Vertex positions of both lips: (2 * (LIP_COLUMNS+1) * (LIP_ROWS+1), 3)."""
    u = np.linspace(-1.0, 1.0, LIP_COLUMNS + 1)
    v = np.linspace(0.0, 1.0, LIP_ROWS + 1)
    uu, vv = np.meshgrid(u, v)
    upper_out, upper_in, lower_in, lower_out = (np.broadcast_to(c, uu.shape) for c in _contours(u, shape))
    depth = -shape["wrap"] * uu**2 + shape["fullness"] * np.sqrt(np.clip(1 - uu**2, 0, 1)) * np.sin(np.pi * (0.1 + 0.8 * vv))
    parts = []
    for outer, inner in ((upper_out, upper_in), (lower_out, lower_in)):
        y = outer * (1 - vv) + inner * vv
        parts.append(np.stack([uu, y, depth], axis=-1).reshape(-1, 3))
    return np.concatenate(parts).astype(np.float32)


def skin_vertices(shape: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """Skin grid positions (N, 3) and a per-vertex mouth weight (N,) (1 inside the mouth opening)."""
    x = np.linspace(-SKIN_HALF_WIDTH, SKIN_HALF_WIDTH, SKIN_COLUMNS + 1)
    y = np.linspace(-SKIN_HALF_HEIGHT, SKIN_HALF_HEIGHT, SKIN_ROWS + 1)
    xx, yy = np.meshgrid(x, y)
    _, upper_in, lower_in, _ = _contours(np.clip(xx, -1, 1), shape)
    inside = (np.abs(xx) < 0.97) & (yy < upper_in + 0.02) & (yy > lower_in - 0.02)
    z = -shape["wrap"] * np.minimum(xx**2, 1.6) - 0.04 - MOUTH_DEPTH * inside
    return np.stack([xx, yy, z], -1).reshape(-1, 3).astype(np.float32), inside.reshape(-1).astype(np.float32)


def _skin_material() -> bpy.types.Material:
    material = bpy.data.materials.new(SKIN_MATERIAL)
    enable_nodes(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    skin = nodes["Principled BSDF"]
    skin.inputs["Roughness"].default_value = 0.5
    mouth = nodes.new("ShaderNodeAttribute")
    mouth.attribute_name = "mouth"
    mix = nodes.new("ShaderNodeMix")
    mix.name = "Skin Or Mouth"
    mix.data_type = "RGBA"
    mix.inputs[7].default_value = (0.02, 0.004, 0.004, 1.0)
    links.new(mouth.outputs["Fac"], mix.inputs["Factor"])
    links.new(mix.outputs[2], skin.inputs["Base Color"])
    return material


def build_lips_scene() -> bpy.types.Scene:
    """Get or create the lips scene (geometry at source 0)."""
    return get_or_create_scene(SCENE_NAME, _build)


def _build(scene: bpy.types.Scene) -> None:
    shape = lip_shape(np.random.default_rng(0))
    lips = mesh_object(scene, LIPS_OBJECT, lip_vertices(shape),
                        grid_faces(LIP_COLUMNS, LIP_ROWS) + grid_faces(LIP_COLUMNS, LIP_ROWS, (LIP_COLUMNS + 1) * (LIP_ROWS + 1)),
                        lipstick_material(LIPS_MATERIAL))
    lips.pass_index = LIPS_PASS_INDEX
    u = np.linspace(0, 1, LIP_COLUMNS + 1)
    v = np.linspace(0, 1, LIP_ROWS + 1)
    uv_per_vertex = np.tile(np.stack(np.meshgrid(u, v), -1).reshape(-1, 2), (2, 1))
    uv_layer = lips.data.uv_layers.new(name="UVMap")
    loop_vertices = np.zeros(len(lips.data.loops), dtype=np.int32)
    lips.data.loops.foreach_get("vertex_index", loop_vertices)
    uv_layer.data.foreach_set("uv", uv_per_vertex[loop_vertices].reshape(-1))
    skin_positions, _ = skin_vertices(shape)
    skin = mesh_object(scene, SKIN_OBJECT, skin_positions, grid_faces(SKIN_COLUMNS, SKIN_ROWS), _skin_material())
    skin.data.attributes.new("mouth", "FLOAT", "POINT")
    finish_scene(scene, "VTO Camera", 62.0, None, apply_source)


def lip_tone(skin: np.ndarray, shift: float = float(np.mean(LIP_SHIFT_RANGE))) -> np.ndarray:
    """The bare lips' sRGB tone (3,) for a skin's sRGB tone (3,): redder and darker by `shift` x LIP_TONE_SHIFT."""
    return np.clip(np.asarray(skin, np.float64) + np.array(LIP_TONE_SHIFT) * shift, 0.02, 1)


def _draw_tones(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    tone = np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))], dtype=np.float64) / 255.0
    tone = np.clip(tone * rng.uniform(0.92, 1.08, 3), 0, 1)
    return tone, lip_tone(tone, rng.uniform(*LIP_SHIFT_RANGE))


def _source_rng(source_seed: int) -> np.random.Generator:
    return np.random.default_rng([int(source_seed), 0x11B5])


def source_tones(source_seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The sRGB tones (3,) of the skin and the bare lips that `source_seed` gives the scene (no bpy needed)."""
    rng = _source_rng(source_seed)
    lip_shape(rng)
    return _draw_tones(rng)


def apply_source(scene: bpy.types.Scene, source_seed: int,
                 tones: tuple[np.ndarray, np.ndarray] | None = None, light_seed: int | None = None) -> None:
    """Set shape, tones, lighting and camera of the lips scene from `source_seed`, in place; `tones` (the skin's and
    the bare lips' sRGB (3,) each) replace the seed's own tones where given, and the light source `light_seed` draws
    replaces the seed's own where given (the same lips and camera under another of the scene's lights)."""
    rng = _source_rng(source_seed)
    shape = lip_shape(rng)
    lips = scene.objects[LIPS_OBJECT]
    lips.data.vertices.foreach_set("co", lip_vertices(shape).reshape(-1))
    skin = scene.objects[SKIN_OBJECT]
    skin_positions, mouth = skin_vertices(shape)
    skin.data.vertices.foreach_set("co", skin_positions.reshape(-1))
    skin.data.attributes["mouth"].data.foreach_set("value", mouth)
    lips.data.update()
    skin.data.update()

    tone, lips_tone = _draw_tones(rng)  # drawn even where `tones` replaces them: the light and camera draws follow
    if tones is not None:
        tone, lips_tone = (np.clip(np.nan_to_num(np.asarray(t, np.float64)), 0, 1) for t in tones)
    skin_material = bpy.data.materials[SKIN_MATERIAL].node_tree.nodes
    skin_material["Skin Or Mouth"].inputs[6].default_value = (*srgb_to_linear(tone), 1.0)
    lips_material = bpy.data.materials[LIPS_MATERIAL].node_tree.nodes
    lips_material["Bare Lips"].inputs["Base Color"].default_value = (*srgb_to_linear(lips_tone), 1.0)

    randomise_light(scene, rng)
    if light_seed is not None:  # drawn after the seed's own, so the camera's draws below stay the seed's
        other = _source_rng(light_seed)
        lip_shape(other), _draw_tones(other)
        randomise_light(scene, other)

    camera = scene.camera
    camera.location = (rng.normal(0, 0.08), rng.normal(-0.05, 0.08), rng.uniform(3.6, 4.4))
    camera.rotation_euler = (rng.normal(0, 0.02), rng.normal(0, 0.02), rng.normal(0, 0.04))
    record_source(scene, source_seed, tones, light_seed)


def lips_mask(source_seed: int, res: int, lighting: str | None = None) -> np.ndarray:
    """Where the lips are in a res x res render of the default scene with `source_seed`, lit the `lighting` way:
    (res, res) bool."""
    return region_mask(build_lips_scene, apply_source, source_seed, res, lighting)
