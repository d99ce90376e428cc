"""The photo lips scene: a real portrait's lips as a mesh (from the face mesh, with its depth) seen by an orthographic
camera that lands every vertex on its pixel of the photo's lips frame, under the photo's light, wearing the
"VTO Lipstick" group over the photo's own lip colour. blender_addon.renderers.tryon renders it.

Coordinates: a frame of n x n pixels; the mesh's x is the frame's u (right), its y is n - v (up), its z points at the
camera; the camera sees exactly [0, n] x [0, n].
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from ..compat import enable_nodes
from .nodes_lipstick import lipstick_material

SCENE_NAME = "VTO Photo Lips"
LIPS_OBJECT = "VTO Photo Lips Mesh"
LIPS_MATERIAL = "VTO Photo Lips Material"
CAMERA, KEY, SKIN = "VTO Photo Lips Camera", "VTO Photo Lips Key", "VTO Photo Lips Skin"
CAMERA_HEIGHT = 1000.0  # frame px above the lips: far beyond their depth
WORLD_STRENGTH = 0.3  # the soft fill of a portrait studio, around the face
KEY_STRENGTH = 1.5  # a key light from above the camera, where a studio's sits: it places the gloss's highlight
KEY_ELEVATION = math.radians(35)  # the key's angle above the camera's axis


def build_photo_scene() -> bpy.types.Scene:
    """Get or create the photo lips scene (an empty lips mesh until set_lips)."""
    scene = bpy.data.scenes.get(SCENE_NAME)
    if scene is not None:
        return scene
    scene = bpy.data.scenes.new(SCENE_NAME)
    camera = bpy.data.objects.new(CAMERA, bpy.data.cameras.new(CAMERA))
    camera.data.type = "ORTHO"
    camera.data.clip_start, camera.data.clip_end = 1.0, 2 * CAMERA_HEIGHT
    scene.collection.objects.link(camera)
    scene.camera = camera
    world = bpy.data.worlds.new(SCENE_NAME)
    enable_nodes(world)
    scene.world = world
    key = bpy.data.objects.new(KEY, bpy.data.lights.new(KEY, "SUN"))
    key.data.energy = KEY_STRENGTH
    key.rotation_euler = (-KEY_ELEVATION, 0.0, 0.0)  # from above the camera, pointing down at the lips
    scene.collection.objects.link(key)
    # The face around the lips, which a glossy product reflects (as the default scene's skin is): seen in
    # reflections only, never by the camera, so every pixel the camera sees off the lips is the world's.
    skin_mesh = bpy.data.meshes.new(SKIN)
    skin_mesh.from_pydata([(-1, -1, 0), (2, -1, 0), (2, 2, 0), (-1, 2, 0)], [], [(0, 1, 2, 3)])
    skin = bpy.data.objects.new(SKIN, skin_mesh)
    skin_material = bpy.data.materials.new(SKIN)
    enable_nodes(skin_material)
    skin_mesh.materials.append(skin_material)
    skin.visible_camera = False
    scene.collection.objects.link(skin)
    lips = bpy.data.objects.new(LIPS_OBJECT, bpy.data.meshes.new(LIPS_OBJECT))
    lips.data.materials.append(lipstick_material(LIPS_MATERIAL))
    scene.collection.objects.link(lips)
    return scene


def set_lips(scene: bpy.types.Scene, vertices: np.ndarray, quads: list[tuple[int, int, int, int]], uvs: np.ndarray,
             size: int) -> None:
    """The lips mesh (vertices (V, 3) in frame px, z towards the camera; quads; UVs (V, 2)) in place of the last,
    and the camera over the size x size frame."""
    mesh = bpy.data.objects[LIPS_OBJECT].data
    mesh.clear_geometry()
    world = np.column_stack([vertices[:, 0], size - vertices[:, 1], vertices[:, 2]])
    mesh.from_pydata(world.tolist(), [], quads)  # lips_mesh's quads face the camera once y is up
    uv_layer = mesh.uv_layers.new(name="UVMap")
    corners = np.zeros(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    uv_layer.data.foreach_set("uv", np.asarray(uvs, np.float32)[corners].reshape(-1))
    mesh.shade_smooth()
    skin = bpy.data.objects[SKIN]
    skin.scale = (size, size, 1.0)  # the unit square grown to (-1..2) x size: the frame and its surround
    skin.location = (0.0, 0.0, float(world[:, 2].min()) - 1.0) if len(world) else (0.0, 0.0, -1.0)
    camera = scene.camera
    camera.data.ortho_scale = float(size)
    camera.location = (size / 2, size / 2, CAMERA_HEIGHT)
    camera.rotation_euler = (0.0, 0.0, 0.0)


def set_light_and_lips(scene: bpy.types.Scene, cast: np.ndarray, albedo: np.ndarray, skin: np.ndarray) -> None:
    """The photo's light colour (cast (3,), linear gains of mean 1) on the world and the key, the bare lips' albedo
    (3,) linear (the photo's own lip colour under the layer) and the skin's around them."""
    colour = tuple(float(c) for c in np.clip(cast, 0.05, 20.0)) + (1.0,)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = colour
    background.inputs["Strength"].default_value = WORLD_STRENGTH
    bpy.data.objects[KEY].data.color = colour[:3]
    face = bpy.data.materials[SKIN].node_tree.nodes["Principled BSDF"]
    face.inputs["Base Color"].default_value = tuple(float(c) for c in np.clip(skin, 0.01, 0.95)) + (1.0,)
    set_bare_lips(albedo)


def set_bare_lips(albedo: np.ndarray) -> None:
    """The bare lips' albedo (3,) linear, under the layer."""
    bare = bpy.data.materials[LIPS_MATERIAL].node_tree.nodes["Bare Lips"]
    bare.inputs["Base Color"].default_value = tuple(float(c) for c in np.clip(albedo, 0.01, 0.95)) + (1.0,)


def lips_group_node(scene: bpy.types.Scene) -> bpy.types.Node:
    """The "VTO Lipstick" node of the photo lips' material."""
    return bpy.data.materials[LIPS_MATERIAL].node_tree.nodes["VTO Lipstick"]
