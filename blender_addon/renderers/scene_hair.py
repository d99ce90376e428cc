"""The default hair scene: Cycles hair curves on a head, HDRI light, hair mask from the object-index pass.

Built once; `apply_source` moves the strands, recolours and relights in place (no data blocks per sample).
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from vto_core.colour import hsv_to_rgb, srgb_to_linear
from vto_core.errors import VtoError

from ..compat import enable_nodes
from .lighting import build_hdri_world, randomise_hdri
from .scene_build import SKIN_TONES, get_or_create_scene, uv_sphere

SCENE_NAME = "VTO Hair"
HAIR_OBJECT = "VTO Hair Strands"
HEAD_OBJECT = "VTO Head"
HAIR_MATERIAL = "VTO Hair Material"
HEAD_MATERIAL = "VTO Head Material"
HAIR_PASS_INDEX = 1
STRANDS, POINTS_PER_STRAND = 20000, 16
HEAD_RADIUS = 1.0
RADIAL_ROUGHNESS = 0.8
# Strand radius at the root and the tip, in head radii: thin enough that single strands and clumps read as hair at
# 128-512 px, thick enough that 20,000 of them hide the scalp.
ROOT_RADIUS, TIP_RADIUS = 0.005, 0.002
VIEWS = ("region", "portrait")  # a close-up that hair fills (the default source: what an artist gives) | the whole head


def _roots(rng: np.random.Generator, count: int, hairline: float) -> tuple[np.ndarray, np.ndarray]:
    """(azimuth, polar) of `count` roots on the scalp: the crown down to 110 degrees, the face kept free below a
    hairline `hairline` radians above it. The camera of the portrait view looks from -y (azimuth -pi/2)."""
    azimuth = rng.uniform(0, 2 * math.pi, count)
    facing = np.cos(azimuth + math.pi / 2)  # 1 at the face, -1 at the back
    max_polar = np.radians(110) - hairline * np.clip(facing, 0, 1)
    polar = np.arccos(1 - rng.random(count) * (1 - np.cos(max_polar)))
    return azimuth, polar


def _combed(azimuth: np.ndarray, polar: np.ndarray, shell: np.ndarray, lengths: np.ndarray, parting: float):
    """Strands (n, POINTS_PER_STRAND, 3) combed over a shell of radius `shell` (n,) from their roots, then falling
    straight down; front strands go back over the crown so the face stays clear. Also the azimuth each point lies at
    (n, POINTS_PER_STRAND)."""
    arc = np.linspace(0, 1, POINTS_PER_STRAND)[None, :] * lengths[:, None]
    from_face = (azimuth + math.pi / 2 + math.pi) % (2 * math.pi) - math.pi  # 0 at the face
    front = (np.abs(from_face) < np.radians(80 + 10 * parting))[:, None]
    radius = shell[:, None]
    signed = np.where(front, polar[:, None] - arc / radius, polar[:, None] + arc / radius)  # < 0: over the crown
    phi = azimuth[:, None] + math.pi * (signed < 0)
    limit = np.radians(100)  # past 100 degrees from the crown every strand falls straight down
    over = np.minimum(np.abs(signed), limit)
    fall = np.maximum(arc - np.where(front, polar[:, None] + limit, limit - polar[:, None]) * radius, 0)
    points = np.stack([radius * np.sin(over) * np.cos(phi), radius * np.sin(over) * np.sin(phi),
                       radius * np.cos(over) - fall], -1)
    return points, phi


def _unit_vectors(azimuth: np.ndarray, polar: np.ndarray) -> np.ndarray:
    """(n, 3) directions of (azimuth, polar) pairs."""
    return np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)], -1)


def strand_positions(rng: np.random.Generator) -> np.ndarray:
    """Procedural hairstyle: strand points (STRANDS * POINTS_PER_STRAND, 3).

    Strands are combed over the head and fall below it; each drifts towards the path of its clump's guide strand
    the further it is from its root (locks), clumps wave sideways (straight or wavy hair), and tips fray.
    """
    length, parting, hairline = rng.uniform(0.8, 3.0), rng.uniform(-0.4, 0.4), np.radians(rng.uniform(55, 75))
    wave_amplitude = rng.uniform(0.02, 0.1) if rng.random() < 0.5 else 0.0
    waves_per_length, clumps, pull = rng.uniform(2.0, 5.0), int(rng.integers(80, 400)), rng.uniform(0.4, 0.9)
    azimuth, polar = _roots(rng, STRANDS, hairline)
    shell = HEAD_RADIUS * (1.02 + 0.06 * rng.random(STRANDS) ** 2)  # layers: most strands lie close to the head
    lengths = length * rng.uniform(0.8, 1.1, STRANDS)
    points, phi = _combed(azimuth, polar, shell, lengths, parting)
    guide_azimuth, guide_polar = _roots(rng, clumps, hairline)
    guides, _ = _combed(guide_azimuth, guide_polar, np.full(clumps, 1.05 * HEAD_RADIUS),
                        length * rng.uniform(0.85, 1.05, clumps), parting)
    clump = np.argmax(_unit_vectors(azimuth, polar) @ _unit_vectors(guide_azimuth, guide_polar).T, axis=1)
    along = np.linspace(0, 1, POINTS_PER_STRAND)[None, :, None]
    target = guides[clump] + (points[:, :1] - guides[clump][:, :1]) * (1 - along)  # the guide's path from this root
    points += pull * along**0.7 * (target - points)
    phase = rng.uniform(0, 2 * math.pi, clumps)[clump][:, None]
    wave = wave_amplitude * np.sin(2 * math.pi * waves_per_length * along[..., 0] * lengths[:, None] / length + phase)
    sideways = np.stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)], -1)
    points += (wave * along[..., 0] ** 0.5)[..., None] * sideways
    points += rng.normal(0, 0.006, points.shape) * along
    return points.reshape(-1, 3).astype(np.float32)


def _hair_material() -> bpy.types.Material:
    material = bpy.data.materials.new(HAIR_MATERIAL)
    enable_nodes(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    hair = nodes.new("ShaderNodeBsdfHairPrincipled")
    hair.name = "Hair BSDF"
    hair.parametrization = "MELANIN"  # before touching Melanin: other parametrisations hide it
    hair.inputs["Roughness"].default_value = 0.3
    # Glints smoothed: at Blender's default 0.3 back-lit strands glint, and at 64 px / 16 spp that noise (up to
    # 9.7/255 on 4x4 block means of the hair) hid the hair stage's parameter changes; 0.8 cuts the noisiest sources'
    # noise by 40-50 % (benchmarks/results/hair_match.md).
    hair.inputs["Radial Roughness"].default_value = RADIAL_ROUGHNESS
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(hair.outputs[0], output.inputs["Surface"])
    return material


def _head_material() -> bpy.types.Material:
    material = bpy.data.materials.new(HEAD_MATERIAL)
    enable_nodes(material)
    material.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.5
    return material


def build_hair_scene() -> bpy.types.Scene:
    """Get or create the hair scene (strands at source 0)."""
    return get_or_create_scene(SCENE_NAME, _build)


def _build(scene: bpy.types.Scene) -> None:
    mesh = bpy.data.meshes.new(HEAD_OBJECT)
    mesh.from_pydata(*uv_sphere(48, 24, HEAD_RADIUS))
    mesh.shade_smooth()
    mesh.materials.append(_head_material())
    head = bpy.data.objects.new(HEAD_OBJECT, mesh)
    head.scale = (0.85, 1.0, 1.15)
    scene.collection.objects.link(head)

    curves = bpy.data.hair_curves.new(HAIR_OBJECT)
    curves.add_curves([POINTS_PER_STRAND] * STRANDS)
    curves.materials.append(_hair_material())
    hair = bpy.data.objects.new(HAIR_OBJECT, curves)
    hair.pass_index = HAIR_PASS_INDEX
    hair.scale = head.scale
    scene.collection.objects.link(hair)
    radius = curves.attributes.new("radius", "FLOAT", "POINT")
    taper = np.linspace(ROOT_RADIUS, TIP_RADIUS, POINTS_PER_STRAND, dtype=np.float32)
    radius.data.foreach_set("value", np.tile(taper, STRANDS))

    camera = bpy.data.objects.new("VTO Hair Camera", bpy.data.cameras.new("VTO Hair Camera"))
    camera.data.lens = 45.0
    scene.collection.objects.link(camera)
    scene.camera = camera

    build_hdri_world(scene)
    scene.view_layers[0].use_pass_object_index = True
    apply_source(scene, 0)


def apply_source(scene: bpy.types.Scene, source_seed: int, view: str = "region") -> None:
    """Set hairstyle, hair and skin colour, lighting and camera from `source_seed`, in place.

    view: "region", a close-up from behind or the side that the hair fills (what an artist gives: hair, not a head),
    or "portrait", the whole head from the front. Both views of a seed show the same hair under the same light.
    """
    if view not in VIEWS:
        raise VtoError(f"hair view is {' or '.join(VIEWS)}, got '{view}'")
    rng = np.random.default_rng([int(source_seed), 0x4A12])
    points = strand_positions(rng)
    curves = scene.objects[HAIR_OBJECT].data
    curves.position_data.foreach_set("vector", points.reshape(-1))
    curves.update_tag()
    hair = bpy.data.materials[HAIR_MATERIAL].node_tree.nodes["Hair BSDF"]
    # Melanin 0 is unpigmented (platinum, white), 1 black; redness from ash to copper; a quarter of the heads dyed.
    hair.inputs["Melanin"].default_value = rng.uniform(0.0, 1.0)
    hair.inputs["Melanin Redness"].default_value = rng.uniform(0.0, 1.0)
    dyed = rng.random() < 0.25
    tint = hsv_to_rgb(np.array([rng.random(), rng.uniform(0.3, 0.8), 1.0]))
    hair.inputs["Tint"].default_value = (*(srgb_to_linear(tint) if dyed else np.ones(3)), 1.0)
    hair.inputs["Roughness"].default_value = rng.uniform(0.2, 0.45)
    hair.inputs["Random Color"].default_value = rng.uniform(0.05, 0.3)
    hair.inputs["Random Roughness"].default_value = rng.uniform(0.0, 0.3)
    tone = np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))]) / 255.0
    head = bpy.data.materials[HEAD_MATERIAL].node_tree.nodes["Principled BSDF"]
    head.inputs["Base Color"].default_value = (*srgb_to_linear(tone), 1.0)

    randomise_hdri(scene, rng, (0.7, 1.5))

    turn = rng.normal(0, 0.25)
    scene.objects[HEAD_OBJECT].rotation_euler = (0.0, 0.0, turn)
    scene.objects[HAIR_OBJECT].rotation_euler = scene.objects[HEAD_OBJECT].rotation_euler
    front = ((rng.normal(0, 0.1), -5.2 + rng.normal(0, 0.2), 0.35 + rng.normal(0, 0.1)),
             (math.radians(88) + rng.normal(0, 0.02), 0.0, rng.normal(0, 0.02)))
    # The close-up: from behind or a side (up to 110 degrees from straight behind), a little above or below, aimed
    # at a point of the hair mass.
    azimuth = math.pi / 2 + turn + rng.uniform(-1.0, 1.0) * math.radians(110)
    elevation, distance, aim = math.radians(rng.uniform(-5, 35)), rng.uniform(2.2, 3.0), rng.uniform(-0.4, 0.5)
    direction = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                          math.sin(elevation)])
    location = np.array([0.0, 0.0, aim]) + distance * direction
    camera = scene.camera
    if view == "portrait":
        camera.location, camera.rotation_euler = front
    else:
        camera.location = tuple(location)
        camera.rotation_euler = (math.pi / 2 - elevation, 0.0, azimuth + math.pi / 2)
    scene["vto_source_seed"] = int(source_seed)
    scene["vto_view"] = view
