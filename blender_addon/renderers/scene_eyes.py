"""The default eye scene: one procedural eye (eyeball, lids, crease, brow bone, brow, lashes) on skin, HDRI light and
camera jitter, all set by a source seed.

The scene is built once; `apply_source` then changes vertex positions, attributes, colours and the world in place,
so that a long dataset run creates no data blocks per sample. Units: the eye opening is about 1 wide; x runs from the
outer corner (-x) to the inner one (+x, the nose), y up, z toward the camera. The lid is an object of its own, from
the lid margin up to the brow's lower edge (the face mesh's lid loop, vto_core.products.EYELIDS), wearing the
"VTO Eye Shadow" group; its points carry the lid coordinates the group reads.
"""

from __future__ import annotations

import bpy
import numpy as np

from vto_core.colour import srgb_to_linear
from vto_core.errors import VtoError

from ..compat import enable_nodes
from .nodes_eyeshadow import ACROSS_ATTRIBUTE, LID_ATTRIBUTE, eyeshadow_material
from .scene_build import (REGION_PASS_INDEX, SKIN_TONES, finish_scene, get_or_create_scene, grid_faces, mesh_object,
                          randomise_light, record_source, region_mask, uv_sphere)

SCENE_NAME = "VTO Eye"
LID_OBJECT, SKIN_OBJECT = "VTO Eyelid", "VTO Eye Skin"
EYEBALL_OBJECT, LASH_OBJECT = "VTO Eyeball", "VTO Lashes"
LID_MATERIAL, SKIN_MATERIAL = "VTO Eyelid Material", "VTO Eye Skin Material"
EYEBALL_MATERIAL, LASH_MATERIAL = "VTO Eyeball Material", "VTO Lash Material"
EYELID_PASS_INDEX = REGION_PASS_INDEX  # the lid's object index: the IndexOB pass of a render is the lid mask

HALF_OPENING = 0.47  # the eye opening's half width: the lid margin runs from x = -HALF_OPENING to +HALF_OPENING
# The lid region's ends in x: MediaPipe's lid loop is ~1.6 eye openings wide, reaching further out than in.
LID_OUTER, LID_INNER = -0.85, 0.72
X_EXTENT, Y_TOP, Y_BOTTOM = 1.7, 1.9, -1.5  # the skin grid's reach, past the frame at any jitter
# Columns of the skin grids, in spans between the x where the lid, the opening and the grid change.
COLUMN_SPANS = ((-X_EXTENT, LID_OUTER, 26), (LID_OUTER, -HALF_OPENING, 14), (-HALF_OPENING, HALF_OPENING, 36),
                (HALF_OPENING, LID_INNER, 10), (LID_INNER, X_EXTENT, 32))
LID_ROWS, ABOVE_ROWS, BELOW_ROWS = 26, 34, 40  # lid margin -> brow edge, brow edge -> top, lower margin -> bottom
EYEBALL_RADIUS = 0.52
LID_THICKNESS = 0.035
LID_FLATNESS = 0.75  # the upper lid drapes over the eyeball flatter than the eyeball is (its skin and fat fill in)
IRIS_RADIUS, PUPIL_RADIUS = 0.46, 0.19  # in eyeball radii, across the gaze axis
LASHES_UPPER, LASHES_LOWER = 64, 28
LASH_SEGMENTS = 4
FRAME_SHARE = 0.8  # the lid region's width over the frame's aimed at (vto_core.products.EYELID_FRAME_SHARE: as seen)
LENS, SENSOR = 62.0, 36.0  # mm

LID_TONE = (0.93, 0.85, 0.86)  # bare lids: a darker, pinker skin (linear factors), fading to the skin at its edges
# sRGB 8-bit tones of irises and brows.
IRIS_TONES = [(52, 30, 18), (92, 56, 30), (120, 92, 48), (82, 104, 66), (74, 108, 146), (108, 116, 122)]
BROW_TONES = [(22, 16, 12), (45, 30, 20), (78, 54, 34), (120, 90, 60), (96, 48, 28)]
LID_SHAPES = ("average", "hooded", "monolid", "deep-set")


def eye_shape(rng: np.random.Generator) -> dict[str, float]:
    """Random shape parameters of one eye region; "kind" indexes LID_SHAPES."""
    kind = int(rng.integers(len(LID_SHAPES)))
    shape = {
        "kind": kind,
        "open_upper": rng.uniform(0.15, 0.25),
        "open_lower": rng.uniform(0.08, 0.13),
        "tilt": rng.uniform(-0.06, 0.14),  # the outer corner's rise per unit x (canthal tilt)
        "skew": rng.uniform(-0.25, 0.15),  # where the upper margin peaks: < 0 toward the inner corner
        "brow_height": rng.uniform(0.6, 0.78),
        "brow_arch": rng.uniform(0.03, 0.14),
        "brow_peak": rng.uniform(-0.6, -0.2),
        "brow_thickness": rng.uniform(0.2, 0.3),
        "brow_ridge": rng.uniform(0.12, 0.22),
        "socket": rng.uniform(0.04, 0.1),
        "crease_gap": rng.uniform(0.2, 0.3),
        "crease_depth": rng.uniform(0.04, 0.07),
        "hood": 0.0,
        "puff": 0.0,
        "gaze_x": rng.normal(0, 0.08),
        "gaze_y": rng.normal(0, 0.06),
    }
    if LID_SHAPES[kind] == "hooded":  # the fold of the brow bone hangs over the crease, nearly to the lashes
        shape.update(crease_gap=rng.uniform(0.07, 0.12), crease_depth=rng.uniform(0.02, 0.04),
                     hood=rng.uniform(0.05, 0.09))
    elif LID_SHAPES[kind] == "monolid":  # no crease: one smooth, fuller lid up to the brow
        shape.update(crease_depth=0.0, puff=rng.uniform(0.03, 0.06), socket=rng.uniform(0.0, 0.03),
                     brow_ridge=rng.uniform(0.08, 0.14), open_upper=rng.uniform(0.1, 0.17))
    elif LID_SHAPES[kind] == "deep-set":  # a strong brow bone over a deep socket and a high, deep crease
        shape.update(crease_gap=rng.uniform(0.28, 0.36), crease_depth=rng.uniform(0.07, 0.1),
                     socket=rng.uniform(0.12, 0.18), brow_ridge=rng.uniform(0.22, 0.32))
    return shape


def _columns() -> np.ndarray:
    """x of the skin grids' columns: (sum of the spans' counts + 1,)."""
    parts = [np.linspace(start, end, count, endpoint=False) for start, end, count in COLUMN_SPANS]
    return np.concatenate(parts + [np.array([COLUMN_SPANS[-1][1]])])


def _lid_columns() -> slice:
    """The columns of the lid region."""
    first = COLUMN_SPANS[0][2]
    return slice(first, first + sum(count for _, _, count in COLUMN_SPANS[1:4]) + 1)


def margins(x: np.ndarray, shape: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """y of the upper and lower lid margins at x; beyond the corners both are the line through them."""
    inside = np.clip(1.0 - (x / HALF_OPENING) ** 2, 0.0, 1.0)
    canthus = -shape["tilt"] * x
    skew = 1.0 + shape["skew"] * np.clip(x / HALF_OPENING, -1, 1)
    upper = canthus + shape["open_upper"] * inside**0.6 * skew
    lower = canthus - shape["open_lower"] * inside**0.8
    return upper, lower


def brow_edge(x: np.ndarray, shape: dict[str, float]) -> np.ndarray:
    """y of the brow's lower edge (the lid region's top) at x."""
    arch = shape["brow_arch"] * np.clip(1.0 - ((x - shape["brow_peak"]) / 1.2) ** 2, -1.0, 1.0)
    return shape["brow_height"] + arch - 0.5 * shape["tilt"] * x


def _smooth_max(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    return k * np.logaddexp(a / k, b / k)


def _ball(x: np.ndarray, y: np.ndarray, radius: float) -> np.ndarray:
    """z of a sphere of `radius` about the eyeball's centre, -1 away from its footprint."""
    inside = radius**2 - x**2 - y**2
    return np.where(inside > 0, -EYEBALL_RADIUS + np.sqrt(np.maximum(inside, 0.0)), -1.0)


def _face(x: np.ndarray, y: np.ndarray, shape: dict[str, float]) -> np.ndarray:
    """z of the face around the eye, before the lids drape over the eyeball."""
    ridge = shape["brow_ridge"] * np.exp(-(((y - brow_edge(x, shape) - 0.18) / 0.32) ** 2))
    socket = shape["socket"] * np.exp(-((x / 0.8) ** 2) - ((y - 0.2) / 0.4) ** 2)
    cheek = 0.1 * np.exp(-(((y + 0.8) / 0.4) ** 2) - ((x + 0.2) / 1.1) ** 2)
    nose = 0.32 * np.clip((x - 0.65) / 0.9, 0, 1) ** 2 * np.clip((y + 1.2) / 1.6, 0, 1)
    temple = 0.16 * np.clip(-x - 0.7, 0, None) ** 2
    return -0.09 + ridge - socket + cheek + nose - temple - 0.04 * np.clip(y - 1.2, 0, None)


def upper_vertices(shape: dict[str, float]) -> np.ndarray:
    """The skin above the lower margin's line: (LID_ROWS + ABOVE_ROWS + 1, columns, 3), row 0 on the upper margin."""
    x = _columns()
    upper, _ = margins(x, shape)
    edge = np.maximum(brow_edge(x, shape), upper + 0.2)
    rows = [upper + (edge - upper) * v for v in np.linspace(0, 1, LID_ROWS + 1)]
    rows += [edge + (Y_TOP - edge) * v for v in np.linspace(0, 1, ABOVE_ROWS + 1)[1:]]
    y = np.stack(rows)
    xx = np.broadcast_to(x, y.shape)
    above = y - upper  # >= 0: how far above the margin
    gate = np.clip(above / 0.05, 0, 1)  # the lid's own terms vanish on the line the lower skin shares
    opening = np.clip(1.0 - (xx / HALF_OPENING) ** 2, 0, 1)
    thickness = LID_THICKNESS * np.clip(above / 0.04, 0, 1)  # the margin rounds into the eyeball
    z = _smooth_max(_face(xx, y, shape), _ball(xx, LID_FLATNESS * y, EYEBALL_RADIUS + thickness), 0.08)
    crease_at = upper + shape["crease_gap"] * (0.35 + 0.65 * opening)
    across = np.clip(1.0 - (xx / (HALF_OPENING + 0.3)) ** 2, 0, 1)
    crease = shape["crease_depth"] * np.exp(-(((y - crease_at) / 0.1) ** 2)) * across
    hood = shape["hood"] * np.exp(-(((y - crease_at - 0.09) / 0.1) ** 2)) * across
    puff = shape["puff"] * np.exp(-(((y - upper - 0.2) / 0.2) ** 2)) * across
    z = z + (hood + puff - crease) * gate
    # The margin itself, inside the opening, sits on the eyeball: no gap to see through at any camera jitter.
    z[0] = _on_eyeball(z[0], x, upper, opening[0])
    return np.stack([xx, y, z], -1).astype(np.float32)


def _on_eyeball(z: np.ndarray, x: np.ndarray, y: np.ndarray, opening: np.ndarray) -> np.ndarray:
    """A margin row's z (columns,), moved onto the eyeball inside the opening, smoothly to nothing at the corners."""
    weight = opening**0.3
    return (1 - weight) * z + weight * (_ball(x, y, EYEBALL_RADIUS) - 0.004)


def lower_vertices(shape: dict[str, float]) -> np.ndarray:
    """The skin below: (BELOW_ROWS + 1, columns, 3), row 0 on the lower margin (shared with the upper's beyond the
    corners)."""
    x = _columns()
    _, lower = margins(x, shape)
    y = np.stack([lower + (Y_BOTTOM - lower) * v ** 1.3 for v in np.linspace(0, 1, BELOW_ROWS + 1)])
    xx = np.broadcast_to(x, y.shape)
    below = lower - y
    opening = np.clip(1.0 - (xx / HALF_OPENING) ** 2, 0, 1)
    thickness = LID_THICKNESS * np.clip(below / 0.04, 0, 1)
    z = _smooth_max(_face(xx, y, shape), _ball(xx, y, EYEBALL_RADIUS + thickness), 0.08)
    z[0] = _on_eyeball(z[0], x, lower, opening[0])
    return np.stack([xx, y, z], -1).astype(np.float32)


def lid_coordinates() -> tuple[np.ndarray, np.ndarray]:
    """The lid's point attributes: its coordinate (0 at the margin, 1 at the brow edge) and along it (-1 at the inner
    end, 1 at the outer), (LID_ROWS + 1, lid columns) each; the same for every source (the grid follows the shape)."""
    x = _columns()[_lid_columns()]
    lid = np.linspace(0, 1, LID_ROWS + 1)[:, None] * np.ones_like(x)
    across = np.broadcast_to(1.0 - 2.0 * (x - LID_OUTER) / (LID_INNER - LID_OUTER), lid.shape)
    return lid.astype(np.float32), np.ascontiguousarray(across, np.float32)


def brow_weight(vertices: np.ndarray, shape: dict[str, float]) -> np.ndarray:
    """How much brow each point of the upper skin (..., 3) shows: (...,) in [0, 1]."""
    x, y = vertices[..., 0], vertices[..., 1]
    edge = brow_edge(x, shape)
    thickness = shape["brow_thickness"] * (0.35 + 0.65 * np.clip((x + 1.15) / 1.3, 0, 1))
    rise = np.clip((y - edge) / 0.035, 0, 1)
    fall = np.clip((edge + thickness - y) / 0.05, 0, 1)
    ends = np.clip((x + 1.2) / 0.15, 0, 1) * np.clip((0.82 - x) / 0.1, 0, 1)
    return (rise * fall * ends).astype(np.float32)


def lash_vertices(shape: dict[str, float], upper_skin: np.ndarray, lower_skin: np.ndarray) -> np.ndarray:
    """Thin ribbons along both margins: (LASHES_UPPER + LASHES_LOWER, LASH_SEGMENTS + 1, 2, 3)."""
    lashes = []
    for count, skin, sign, length, width in ((LASHES_UPPER, upper_skin, 1.0, 0.22, 0.018),
                                             (LASHES_LOWER, lower_skin, -1.0, 0.12, 0.01)):
        x = np.linspace(-0.93, 0.9, count) * HALF_OPENING
        base_x, base_y, base_z = (np.interp(x, skin[0, :, 0], skin[0, :, axis]) for axis in range(3))
        rise = np.clip(1.0 - (x / HALF_OPENING) ** 2, 0.15, 1.0)  # shorter toward the corners
        outward = -0.35 * np.clip(-x / HALF_OPENING, 0, 1)  # outer lashes sweep out
        t = np.linspace(0, 1, LASH_SEGMENTS + 1)[:, None]
        along = length * rise
        px = base_x + outward * along * t**1.5
        py = base_y + sign * along * (0.1 * t + 0.8 * t**2)
        pz = base_z + 0.012 + along * (0.9 * t - 0.45 * t**2)
        half = width * (1.0 - 0.85 * t) / 2
        left = np.stack([px - half, py, pz], -1)
        right = np.stack([px + half, py, pz], -1)
        lashes.append(np.stack([left, right], -2).transpose(1, 0, 2, 3))
    return np.concatenate(lashes).astype(np.float32)


def _lash_faces(count: int) -> list[tuple[int, int, int, int]]:
    per = 2 * (LASH_SEGMENTS + 1)
    return [(n * per + 2 * s, n * per + 2 * s + 1, n * per + 2 * s + 3, n * per + 2 * s + 2)
            for n in range(count) for s in range(LASH_SEGMENTS)]


def _skin_faces() -> list[tuple[int, int, int, int]]:
    columns = len(_columns()) - 1
    lid = _lid_columns()
    upper = grid_faces(columns, LID_ROWS + ABOVE_ROWS,
                        keep=lambda r, c: not (r < LID_ROWS and lid.start <= c < lid.stop - 1))
    return upper + grid_faces(columns, BELOW_ROWS, (LID_ROWS + ABOVE_ROWS + 1) * (columns + 1))


def _principled_material(name: str, roughness: float) -> tuple[bpy.types.Material, bpy.types.Node]:
    material = bpy.data.materials.new(name)
    enable_nodes(material)
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = roughness
    return material, bsdf


def _skin_material() -> bpy.types.Material:
    """Skin with the brow painted on by the 'brow' attribute, broken into strands by a stretched noise."""
    material, skin = _principled_material(SKIN_MATERIAL, 0.5)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    brow = nodes.new("ShaderNodeAttribute")
    brow.attribute_name = "brow"
    strands = nodes.new("ShaderNodeTexNoise")
    strands.inputs["Scale"].default_value = 6.0
    stretch = nodes.new("ShaderNodeMapping")
    stretch.inputs["Scale"].default_value = (4.0, 30.0, 4.0)  # brow hairs run along x
    links.new(nodes.new("ShaderNodeTexCoord").outputs["Object"], stretch.inputs["Vector"])
    links.new(stretch.outputs[0], strands.inputs["Vector"])
    hairs = nodes.new("ShaderNodeMath")
    hairs.operation, hairs.use_clamp = "MULTIPLY", True
    links.new(brow.outputs["Fac"], hairs.inputs[0])
    ramp = nodes.new("ShaderNodeMapRange")
    ramp.inputs["From Min"].default_value, ramp.inputs["From Max"].default_value = 0.35, 0.6
    ramp.inputs["To Min"].default_value, ramp.inputs["To Max"].default_value = 0.55, 1.0
    links.new(strands.outputs["Fac"], ramp.inputs["Value"])
    links.new(ramp.outputs[0], hairs.inputs[1])
    mix = nodes.new("ShaderNodeMix")
    mix.name, mix.data_type = "Skin Or Brow", "RGBA"
    links.new(hairs.outputs[0], mix.inputs["Factor"])
    links.new(mix.outputs[2], skin.inputs["Base Color"])
    return material


def _lid_material() -> bpy.types.Material:
    """The eye-shadow material, its Bare Lid a pinker, darker skin that fades to the skin's tone at the region's edges
    (no seam where the lid object meets the skin)."""
    material = eyeshadow_material(LID_MATERIAL)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    lid, across = nodes.new("ShaderNodeAttribute"), nodes.new("ShaderNodeAttribute")
    lid.attribute_name, across.attribute_name = LID_ATTRIBUTE, ACROSS_ATTRIBUTE
    ends = nodes.new("ShaderNodeMath")
    ends.operation = "ABSOLUTE"
    links.new(across.outputs["Fac"], ends.inputs[0])
    edge = nodes.new("ShaderNodeMath")
    edge.operation = "MAXIMUM"
    links.new(lid.outputs["Fac"], edge.inputs[0])
    links.new(ends.outputs[0], edge.inputs[1])
    fade = nodes.new("ShaderNodeMapRange")
    fade.interpolation_type = "SMOOTHSTEP"
    fade.inputs["From Min"].default_value = 0.4
    links.new(edge.outputs[0], fade.inputs["Value"])
    mix = nodes.new("ShaderNodeMix")
    mix.name, mix.data_type = "Lid Or Skin", "RGBA"
    links.new(fade.outputs[0], mix.inputs["Factor"])
    links.new(mix.outputs[2], nodes["Bare Lid"].inputs["Base Color"])
    return material


def _eyeball_material() -> bpy.types.Material:
    """Sclera, iris and pupil by the distance from the gaze axis (the object's +z), wet (low roughness)."""
    material, eye = _principled_material(EYEBALL_MATERIAL, 0.08)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    parts = nodes.new("ShaderNodeSeparateXYZ")
    links.new(nodes.new("ShaderNodeTexCoord").outputs["Object"], parts.inputs[0])
    across = nodes.new("ShaderNodeVectorMath")
    across.operation = "LENGTH"
    combine = nodes.new("ShaderNodeCombineXYZ")
    links.new(parts.outputs["X"], combine.inputs["X"])
    links.new(parts.outputs["Y"], combine.inputs["Y"])
    links.new(combine.outputs[0], across.inputs[0])
    scaled = nodes.new("ShaderNodeMath")
    scaled.operation = "DIVIDE"
    scaled.inputs[1].default_value = EYEBALL_RADIUS
    links.new(across.outputs["Value"], scaled.inputs[0])
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.name = "Eye Colours"
    elements = ramp.color_ramp.elements
    stops = (0.0, PUPIL_RADIUS, PUPIL_RADIUS + 0.03, IRIS_RADIUS - 0.05, IRIS_RADIUS, IRIS_RADIUS + 0.05)
    elements[0].position, elements[1].position = stops[0], stops[1]
    for stop in stops[2:]:
        elements.new(stop)
    links.new(scaled.outputs[0], ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], eye.inputs["Base Color"])
    return material


def _set_eye_colours(iris: np.ndarray, sclera: np.ndarray) -> None:
    elements = bpy.data.materials[EYEBALL_MATERIAL].node_tree.nodes["Eye Colours"].color_ramp.elements
    linear_iris, linear_sclera = srgb_to_linear(iris), srgb_to_linear(sclera)
    colours = (np.full(3, 0.004), np.full(3, 0.004), linear_iris * 1.2, linear_iris * 0.8, linear_iris * 0.3,
               linear_sclera)
    for element, colour in zip(elements, colours):
        element.color = (*np.clip(colour, 0, 1), 1.0)


def _eyeball_mesh() -> bpy.types.Mesh:
    mesh = bpy.data.meshes.new(EYEBALL_OBJECT)
    mesh.from_pydata(*uv_sphere(48, 24, EYEBALL_RADIUS))
    mesh.shade_smooth()
    mesh.materials.append(_eyeball_material())
    return mesh


def build_eye_scene() -> bpy.types.Scene:
    """Get or create the eye scene (geometry at source 0)."""
    return get_or_create_scene(SCENE_NAME, _build)


def _build(scene: bpy.types.Scene) -> None:
    shape = eye_shape(np.random.default_rng(0))
    lid_columns = _lid_columns().stop - _lid_columns().start - 1
    upper, lower = upper_vertices(shape), lower_vertices(shape)
    lid = mesh_object(scene, LID_OBJECT, upper[: LID_ROWS + 1, _lid_columns()], grid_faces(lid_columns, LID_ROWS),
                       _lid_material())
    lid.pass_index = EYELID_PASS_INDEX
    for name, values in zip((LID_ATTRIBUTE, ACROSS_ATTRIBUTE), lid_coordinates()):
        lid.data.attributes.new(name, "FLOAT", "POINT").data.foreach_set("value", values.reshape(-1))
    skin = mesh_object(scene, SKIN_OBJECT, np.concatenate([upper.reshape(-1, 3), lower.reshape(-1, 3)]),
                        _skin_faces(), _skin_material())
    skin.data.attributes.new("brow", "FLOAT", "POINT")
    lashes = mesh_object(scene, LASH_OBJECT, lash_vertices(shape, upper, lower),
                          _lash_faces(LASHES_UPPER + LASHES_LOWER), _principled_material(LASH_MATERIAL, 0.7)[0])
    lashes.data.materials[0].node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (
        0.004, 0.003, 0.0025, 1.0)
    eyeball = bpy.data.objects.new(EYEBALL_OBJECT, _eyeball_mesh())
    eyeball.location = (0.0, 0.0, -EYEBALL_RADIUS)
    scene.collection.objects.link(eyeball)
    finish_scene(scene, "VTO Eye Camera", LENS, SENSOR, apply_source)


def _draw_tones(rng: np.random.Generator) -> dict[str, np.ndarray]:
    skin = np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))], dtype=np.float64) / 255.0
    skin = np.clip(skin * rng.uniform(0.92, 1.08, 3), 0, 1)
    return {
        "skin": skin,
        "lid": np.clip(skin * np.array(LID_TONE) * rng.uniform(0.95, 1.05), 0, 1),
        "brow": np.array(BROW_TONES[rng.integers(len(BROW_TONES))]) / 255.0 * rng.uniform(0.85, 1.15),
        "iris": np.array(IRIS_TONES[rng.integers(len(IRIS_TONES))]) / 255.0 * rng.uniform(0.85, 1.15),
        "sclera": np.array([0.93, 0.89, 0.86]) * rng.uniform(0.9, 1.0),
    }


def _source_rng(source_seed: int) -> np.random.Generator:
    return np.random.default_rng([int(source_seed), 0xE7E])


def apply_source(scene: bpy.types.Scene, source_seed: int, tones=None, light_seed: int | None = None) -> None:
    """Set shape, tones, lighting and camera of the eye scene from `source_seed`, in place (a source's own tones and
    light: the eye scene takes no others)."""
    if tones is not None or light_seed is not None:
        raise VtoError("the default eye scene shows each source in its own tones and light")
    rng = _source_rng(source_seed)
    shape = eye_shape(rng)
    upper, lower = upper_vertices(shape), lower_vertices(shape)
    lid = scene.objects[LID_OBJECT]
    lid.data.vertices.foreach_set("co", upper[: LID_ROWS + 1, _lid_columns()].reshape(-1))
    skin = scene.objects[SKIN_OBJECT]
    skin.data.vertices.foreach_set("co", np.concatenate([upper.reshape(-1), lower.reshape(-1)]))
    brow = np.concatenate([brow_weight(upper, shape).reshape(-1), np.zeros(lower.shape[0] * lower.shape[1])])
    skin.data.attributes["brow"].data.foreach_set("value", brow.astype(np.float32))
    lashes = scene.objects[LASH_OBJECT]
    lashes.data.vertices.foreach_set("co", lash_vertices(shape, upper, lower).reshape(-1))
    for obj in (lid, skin, lashes):
        obj.data.update()
    scene.objects[EYEBALL_OBJECT].rotation_euler = (-shape["gaze_y"], shape["gaze_x"], 0.0)

    tones = _draw_tones(rng)
    linear = {name: (*srgb_to_linear(np.clip(tone, 0, 1)), 1.0) for name, tone in tones.items()}
    skin_nodes = bpy.data.materials[SKIN_MATERIAL].node_tree.nodes
    skin_nodes["Skin Or Brow"].inputs[6].default_value = linear["skin"]
    skin_nodes["Skin Or Brow"].inputs[7].default_value = linear["brow"]
    lid_nodes = bpy.data.materials[LID_MATERIAL].node_tree.nodes
    lid_nodes["Lid Or Skin"].inputs[6].default_value = linear["lid"]
    lid_nodes["Lid Or Skin"].inputs[7].default_value = linear["skin"]
    _set_eye_colours(np.clip(tones["iris"], 0, 1), np.clip(tones["sclera"], 0, 1))

    randomise_light(scene, rng)

    region = upper[: LID_ROWS + 1, _lid_columns()].reshape(-1, 3)
    low, high = region.min(axis=0), region.max(axis=0)
    distance = (high[0] - low[0]) / FRAME_SHARE * LENS / SENSOR * rng.uniform(0.95, 1.05)
    camera = scene.camera
    camera.location = ((low[0] + high[0]) / 2 + rng.normal(0, 0.03), (low[1] + high[1]) / 2 + rng.normal(0, 0.03),
                       distance)
    camera.rotation_euler = (rng.normal(0, 0.015), rng.normal(0, 0.015), rng.normal(0, 0.04))
    record_source(scene, source_seed)


def eyelid_mask(source_seed: int, res: int, lighting: str | None = None) -> np.ndarray:
    """Where the lid is in a res x res render of the default eye scene with `source_seed`, lit the `lighting` way:
    (res, res) bool."""
    return region_mask(build_eye_scene, apply_source, source_seed, res, lighting)
