"""The default hair scene: Cycles hair curves on a head, HDRI light, hair mask from the object-index pass.

Built once; `apply_source` moves the strands, recolours and relights in place (no data blocks per sample).
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from vto_core.colour import srgb_to_linear

from .compat import enable_nodes
from .lighting import build_hdri_world, randomise_hdri
from .scene_lips import SKIN_TONES

SCENE_NAME = "VTO Hair"
HAIR_OBJECT = "VTO Hair Strands"
HEAD_OBJECT = "VTO Head"
HAIR_MATERIAL = "VTO Hair Material"
HEAD_MATERIAL = "VTO Head Material"
HAIR_PASS_INDEX = 1
STRANDS, POINTS_PER_STRAND = 3000, 8
HEAD_RADIUS = 1.0
RADIAL_ROUGHNESS = 0.8
STRAND_RADIUS = 0.014  # thick enough that 3,000 strands hide the scalp at 64-256 px


def strand_positions(rng: np.random.Generator) -> np.ndarray:
    """Procedural hairstyle: strand points (STRANDS * POINTS_PER_STRAND, 3)."""
    length = rng.uniform(1.2, 2.6)
    parting = rng.uniform(-0.4, 0.4)
    azimuth = rng.uniform(0, 2 * math.pi, STRANDS)
    # The camera looks from -y: keep the face (azimuth near -pi/2) free below a hairline.
    facing = np.cos(azimuth + math.pi / 2)  # 1 at the face, -1 at the back
    max_polar = np.radians(110) - np.radians(rng.uniform(55, 75)) * np.clip(facing, 0, 1)
    polar = np.arccos(1 - rng.random(STRANDS) * (1 - np.cos(max_polar)))
    shell = HEAD_RADIUS * rng.uniform(1.03, 1.08)
    arc = np.linspace(0, 1, POINTS_PER_STRAND)[None, :] * length * rng.uniform(0.85, 1.15, (STRANDS, 1))
    # Front strands are combed back over the crown (the face stays clear); the others flow down the shell.
    # Past 100 degrees from the crown every strand falls straight down.
    from_face = (azimuth + math.pi / 2 + math.pi) % (2 * math.pi) - math.pi  # 0 at the face
    front = (np.abs(from_face) < np.radians(80 + 10 * parting))[:, None]
    signed = np.where(front, polar[:, None] - arc / shell, polar[:, None] + arc / shell)  # < 0: over the crown
    phi = azimuth[:, None] + math.pi * (signed < 0)
    limit = np.radians(100)
    over = np.minimum(np.abs(signed), limit)
    fall = np.maximum(arc - np.where(front, polar[:, None] + limit, limit - polar[:, None]) * shell, 0)
    x = shell * np.sin(over) * np.cos(phi)
    y = shell * np.sin(over) * np.sin(phi)
    z = shell * np.cos(over) - fall
    jitter = rng.normal(0, 0.015, (STRANDS, POINTS_PER_STRAND, 3)) * np.linspace(0, 1, POINTS_PER_STRAND)[None, :, None]
    points = np.stack([x, y, z], -1) + jitter
    return points.reshape(-1, 3).astype(np.float32)


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
    faces += [(at(k, j), at(k + 1, j), at(k + 1, j + 1), at(k, j + 1)) for k in range(rings - 2) for j in range(segments)]
    faces += [(bottom, at(rings - 2, j + 1), at(rings - 2, j)) for j in range(segments)]
    return vertices.tolist(), [], faces


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
    scene = bpy.data.scenes.get(SCENE_NAME)
    if scene is not None:
        return scene
    scene = bpy.data.scenes.new(SCENE_NAME)
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
    radius.data.foreach_set("value", np.full(STRANDS * POINTS_PER_STRAND, STRAND_RADIUS, dtype=np.float32))

    camera = bpy.data.objects.new("VTO Hair Camera", bpy.data.cameras.new("VTO Hair Camera"))
    camera.data.lens = 45.0
    scene.collection.objects.link(camera)
    scene.camera = camera

    build_hdri_world(scene)
    scene.view_layers[0].use_pass_object_index = True
    apply_source(scene, 0)
    return scene


def apply_source(scene: bpy.types.Scene, source_seed: int) -> None:
    """Set hairstyle, hair and skin colour, lighting and camera from `source_seed`, in place."""
    rng = np.random.default_rng([int(source_seed), 0x4A12])
    points = strand_positions(rng)
    curves = scene.objects[HAIR_OBJECT].data
    curves.position_data.foreach_set("vector", points.reshape(-1))
    curves.update_tag()
    hair = bpy.data.materials[HAIR_MATERIAL].node_tree.nodes["Hair BSDF"]
    hair.inputs["Melanin"].default_value = rng.uniform(0.15, 0.95)
    hair.inputs["Melanin Redness"].default_value = rng.uniform(0.0, 0.9)
    hair.inputs["Roughness"].default_value = rng.uniform(0.2, 0.45)
    tone = np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))]) / 255.0
    head = bpy.data.materials[HEAD_MATERIAL].node_tree.nodes["Principled BSDF"]
    head.inputs["Base Color"].default_value = (*srgb_to_linear(tone), 1.0)

    randomise_hdri(scene, rng, (0.7, 1.5))

    scene.objects[HEAD_OBJECT].rotation_euler = (0.0, 0.0, rng.normal(0, 0.25))
    scene.objects[HAIR_OBJECT].rotation_euler = scene.objects[HEAD_OBJECT].rotation_euler
    camera = scene.camera
    camera.location = (rng.normal(0, 0.1), -5.2 + rng.normal(0, 0.2), 0.35 + rng.normal(0, 0.1))
    camera.rotation_euler = (math.radians(88) + rng.normal(0, 0.02), 0.0, rng.normal(0, 0.02))
    scene["vto_source_seed"] = int(source_seed)
