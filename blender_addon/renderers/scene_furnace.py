"""A white furnace: a sphere wearing the VTO Lipstick group in a uniform white world, for energy and colour checks."""

from __future__ import annotations

import bmesh
import bpy
import numpy as np

from vto_core.colour import srgb_to_linear
from vto_core.products import get_spec

from ..compat import enable_nodes
from .nodes_lipstick import lipstick_group
from .cycles import configure_cycles, render_passes
from .scene_build import get_or_create_scene

FURNACE_SCENE = "VTO Furnace"


def furnace_scene() -> bpy.types.Scene:
    """Get or create the furnace (world radiance 1, white diffuse lips): nothing energy-conserving exceeds 1."""
    return get_or_create_scene(FURNACE_SCENE, _build)


def _build(scene: bpy.types.Scene) -> None:
    world = bpy.data.worlds.new(FURNACE_SCENE)
    enable_nodes(world)
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = world
    mesh = bpy.data.meshes.new(FURNACE_SCENE)
    shape = bmesh.new()
    bmesh.ops.create_uvsphere(shape, u_segments=32, v_segments=16, radius=1.0, calc_uvs=True)
    shape.to_mesh(mesh)
    shape.free()
    mesh.shade_smooth()
    material = bpy.data.materials.new(FURNACE_SCENE)
    enable_nodes(material)
    nodes = material.node_tree.nodes
    nodes.clear()
    lips = nodes.new("ShaderNodeBsdfDiffuse")
    lips.inputs["Color"].default_value = (1, 1, 1, 1)
    makeup = nodes.new("ShaderNodeGroup")
    makeup.name = "VTO Lipstick"
    makeup.node_tree = lipstick_group()
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(lips.outputs[0], makeup.inputs["Lips"])
    material.node_tree.links.new(makeup.outputs[0], output.inputs["Surface"])
    mesh.materials.append(material)
    sphere = bpy.data.objects.new(FURNACE_SCENE, mesh)
    sphere.pass_index = 1
    scene.collection.objects.link(sphere)
    camera = bpy.data.objects.new(FURNACE_SCENE + " Camera", bpy.data.cameras.new(FURNACE_SCENE))
    camera.location = (0, 0, 3.2)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.view_layers[0].use_pass_object_index = True


def render_furnace(values: dict[str, float], samples: int = 64, res: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Unclamped, undenoised linear radiance (res, res, 3) of the sphere wearing `values`, and its mask (res, res)."""
    scene = furnace_scene()
    node = bpy.data.materials[FURNACE_SCENE].node_tree.nodes["VTO Lipstick"]
    spec = get_spec("lipstick")
    full = spec.full_values(values)
    for param in spec.params:
        node.inputs[param.socket].default_value = full[param.name]
    configure_cycles(scene, res, samples, 0)
    scene.cycles.sample_clamp_direct = scene.cycles.sample_clamp_indirect = 0.0  # a clamp would hide extra energy
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = scene.cycles.glossy_bounces = scene.cycles.diffuse_bounces = 8
    passes = render_passes(scene)
    sphere = np.abs(passes["IndexOB"][..., 0] - 1) < 0.5
    return passes["Combined"][..., :3], sphere


def seen_colour(linear: np.ndarray, sphere: np.ndarray, rgb: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The furnace sphere's median linear colour (3,), its white (Fresnel) share s and the residual off the set colour.

    A dielectric always reflects some white: seen = set x (1 - s) + s in linear light; rgb: the set 8-bit sRGB (3,).
    The residual is the largest channel difference left once the white share is fitted (linear units).
    """
    seen, target = np.median(linear[sphere], axis=0), srgb_to_linear(np.asarray(rgb, float) / 255)
    away = 1 - target
    white = float(np.dot(seen - target, away) / max(float(np.dot(away, away)), 1e-12))
    residual = float(np.abs(seen - (target * (1 - white) + white)).max())
    return seen, white, residual
