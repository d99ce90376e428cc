"""The photo scene of a product's layer: a real portrait's face region (the lips, an eyelid) as a mesh (from the face
mesh, with its depth) seen by an orthographic camera that lands every vertex on its pixel of the region's frame, under
the photo's light, wearing the product's group over the photo's own colour there. blender_addon.renderers.tryon renders
it. Each product's layer (PhotoLayer) is declared by its Blender side (blender_addon.renderers.product_<name>).

Coordinates: a frame of n x n pixels; the mesh's x is the frame's u (right), its y is n - v (up), its z points at the
camera; the camera sees exactly [0, n] x [0, n].
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import bpy
import numpy as np

from vto_core.appearance import skin_colour

from ..compat import enable_nodes

CAMERA_HEIGHT = 1000.0  # frame px above the region: far beyond its depth
WORLD_STRENGTH = 0.3  # the soft fill of a portrait studio, around the face
KEY_STRENGTH = 1.5  # a key light from above the camera, where a studio's sits: it places the gloss's highlight
KEY_ELEVATION = math.radians(35)  # the key's angle above the camera's axis


@dataclass(frozen=True)
class PhotoLayer:
    """A product's layer as the photo scene renders it on one face region of a portrait."""

    label: str  # in the scene's and its objects' names: "Lips" -> "VTO Photo Lips", "VTO Photo Lips Mesh"
    product: str  # the product's name (its spec checks the values)
    group_name: str  # its node group: "VTO Lipstick"
    material: Callable[[str], bpy.types.Material]  # a new material of that name: bare shader -> the group -> output
    bare_node: str  # the bare shader's node in that material: "Bare Lips"
    mesh: Callable  # (points (468, 2) frame px, depth (468,) or None, region) -> (vertices (V, 3), quads, uvs (V, 2))
    min_width: float  # px across the region (face_regions.region_width) under which it is too small to render onto
    attributes: Callable | None = None  # uvs (V, 2) -> {name: (V,) float32}: the point attributes its group reads
    bare: Callable | None = None  # the skin beside it (3,) linear, in the light's white -> the bare region's (3,)
    # How that skin is read: (the frame (n, n, 3) display, the region's mask (n, n)) -> (3,) linear, or None where
    # too little of it is in the frame.
    skin: Callable[[np.ndarray, np.ndarray], np.ndarray | None] = skin_colour
    core_median: tuple[float, float, float] = (1.0, 1.0, 1.0)  # its core's median over its mean, linear, bare
    # The spread (standard deviation of the log) of the true bare region's level about `bare`'s guess; above 0, Better
    # and Best fit that level beside the product (blender_addon.matching.photo_scene_fit), where the photo shows it.
    bare_spread: float = 0.0

    @property
    def scene_name(self) -> str:
        return f"VTO Photo {self.label}"

    def part(self, what: str) -> str:
        """The name of one of the scene's parts: part("Mesh") -> "VTO Photo Lips Mesh"."""
        return f"{self.scene_name} {what}"


def build_photo_scene(layer: PhotoLayer) -> bpy.types.Scene:
    """Get or create `layer`'s photo scene (an empty region mesh until set_region)."""
    scene = bpy.data.scenes.get(layer.scene_name)
    if scene is not None:
        return scene
    scene = bpy.data.scenes.new(layer.scene_name)
    camera = bpy.data.objects.new(layer.part("Camera"), bpy.data.cameras.new(layer.part("Camera")))
    camera.data.type = "ORTHO"
    camera.data.clip_start, camera.data.clip_end = 1.0, 2 * CAMERA_HEIGHT
    scene.collection.objects.link(camera)
    scene.camera = camera
    world = bpy.data.worlds.new(layer.scene_name)
    enable_nodes(world)
    scene.world = world
    key = bpy.data.objects.new(layer.part("Key"), bpy.data.lights.new(layer.part("Key"), "SUN"))
    key.data.energy = KEY_STRENGTH
    key.rotation_euler = (-KEY_ELEVATION, 0.0, 0.0)  # from above the camera, pointing down at the region
    scene.collection.objects.link(key)
    # The face around the region, which a glossy or metallic product reflects (as the default scene's skin is): seen
    # in reflections only, never by the camera, so every pixel the camera sees off the region is the world's.
    skin_mesh = bpy.data.meshes.new(layer.part("Skin"))
    skin_mesh.from_pydata([(-1, -1, 0), (2, -1, 0), (2, 2, 0), (-1, 2, 0)], [], [(0, 1, 2, 3)])
    skin = bpy.data.objects.new(layer.part("Skin"), skin_mesh)
    skin_material = bpy.data.materials.new(layer.part("Skin"))
    enable_nodes(skin_material)
    skin_mesh.materials.append(skin_material)
    skin.visible_camera = False
    scene.collection.objects.link(skin)
    region = bpy.data.objects.new(layer.part("Mesh"), bpy.data.meshes.new(layer.part("Mesh")))
    region.data.materials.append(layer.material(layer.part("Material")))
    scene.collection.objects.link(region)
    return scene


def set_region(scene: bpy.types.Scene, layer: PhotoLayer, vertices: np.ndarray, quads: list[tuple[int, ...]],
               uvs: np.ndarray, size: int) -> None:
    """The region's mesh (vertices (V, 3) in frame px, z towards the camera; quads; UVs (V, 2); the layer's point
    attributes from them) in place of the last, and the camera over the size x size frame."""
    mesh = bpy.data.objects[layer.part("Mesh")].data
    mesh.clear_geometry()
    world = np.column_stack([vertices[:, 0], size - vertices[:, 1], vertices[:, 2]])
    mesh.from_pydata(world.tolist(), [], quads)  # the meshes' quads face the camera once y is up
    uv_layer = mesh.uv_layers.new(name="UVMap")
    corners = np.zeros(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    uv_layer.data.foreach_set("uv", np.asarray(uvs, np.float32)[corners].reshape(-1))
    for name, values in (layer.attributes(np.asarray(uvs)) if layer.attributes else {}).items():
        mesh.attributes.new(name, "FLOAT", "POINT").data.foreach_set("value", np.asarray(values, np.float32))
    mesh.shade_smooth()
    skin = bpy.data.objects[layer.part("Skin")]
    skin.scale = (size, size, 1.0)  # the unit square grown to (-1..2) x size: the frame and its surround
    skin.location = (0.0, 0.0, float(world[:, 2].min()) - 1.0) if len(world) else (0.0, 0.0, -1.0)
    camera = scene.camera
    camera.data.ortho_scale = float(size)
    camera.location = (size / 2, size / 2, CAMERA_HEIGHT)
    camera.rotation_euler = (0.0, 0.0, 0.0)


def set_light_and_region(scene: bpy.types.Scene, layer: PhotoLayer, cast: np.ndarray, albedo: np.ndarray,
                         skin: np.ndarray) -> None:
    """The photo's light colour (cast (3,), linear gains of mean 1) on the world and the key, the bare region's albedo
    (3,) linear (the photo's own colour under the layer) and the skin's around it."""
    colour = tuple(float(c) for c in np.clip(cast, 0.05, 20.0)) + (1.0,)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = colour
    background.inputs["Strength"].default_value = WORLD_STRENGTH
    bpy.data.objects[layer.part("Key")].data.color = colour[:3]
    face = bpy.data.materials[layer.part("Skin")].node_tree.nodes["Principled BSDF"]
    face.inputs["Base Color"].default_value = tuple(float(c) for c in np.clip(skin, 0.01, 0.95)) + (1.0,)
    set_bare(layer, albedo)


def set_bare(layer: PhotoLayer, albedo: np.ndarray) -> None:
    """The bare region's albedo (3,) linear, under the layer."""
    bare = bpy.data.materials[layer.part("Material")].node_tree.nodes[layer.bare_node]
    bare.inputs["Base Color"].default_value = tuple(float(c) for c in np.clip(albedo, 0.01, 0.95)) + (1.0,)


def group_node(layer: PhotoLayer) -> bpy.types.Node:
    """The layer's group node in its photo material."""
    return bpy.data.materials[layer.part("Material")].node_tree.nodes[layer.group_name]
