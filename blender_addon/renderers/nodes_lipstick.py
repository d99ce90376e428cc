"""The "VTO Lipstick" shader node group: a makeup layer mixed over the lips' own shader by opacity."""

from __future__ import annotations

import bpy

from vto_core.products import get_spec

from .node_utils import Builder, add_spec_inputs, get_or_create_group, layer_material

GROUP_NAME = "VTO Lipstick"
SRGB_GROUP_NAME = "VTO sRGB 255 to Linear"
SHADER_TREE = "ShaderNodeTree"

# Looks chosen by eye at 64-256 px on the default lips scene.
BASE_ROUGHNESS = 0.5
# Gloss sets the coat's reflectance at normal incidence, F0 = GLOSS_F0_MAX * gloss / (gloss + 1): 0 without gloss,
# saturating smoothly as gloss -> inf; the coat's IOR is the one with that F0 (Fresnel rises to 1 at grazing).
GLOSS_F0_MAX = 0.3
REFLECTION_IOR = 6.0  # the mirror layer's Fresnel: 51 % at normal incidence at Reflection 1, 100 % at grazing
REFLECTION_ROUGHNESS = 0.03
# Sparkle flakes live in the object's own space, sized so that a flake covers about a pixel at the 64 px
# training size on the default lips (2 units across the frame's 2.3): smaller flakes are invisible to an encoder.
SPARKLE_CELLS_PER_UNIT = 14.0
SPARKLE_RADIUS_MIN, SPARKLE_RADIUS_MAX = 0.15, 0.5  # flake radius in cell units over Sparkle Size [0, 1]
SPARKLE_ROUGHNESS = 0.15
LIP_LINE_WIDTH = 0.25  # in UV v, from the outer contour
LIP_LINE_DARKENING = 0.75
TEXTURE_SCALE = 9.0  # noise features of about 3 px at 64 px on the default lips
TEXTURE_BUMP_STRENGTH = 0.6


def _build_srgb(group: bpy.types.NodeTree) -> None:
    """R, G, B in [0,255] (sRGB) -> linear Color, with the exact IEC 61966-2-1 curve per channel."""
    for name in ("R", "G", "B"):
        socket = group.interface.new_socket(name, in_out="INPUT", socket_type="NodeSocketFloat")
        socket.min_value, socket.max_value = 0.0, 255.0
    group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    b = Builder(group, "Shader")
    inputs = b.node("NodeGroupInput")
    combine = b.node("CombineColor")
    for index in range(3):
        encoded = b.math("DIVIDE", inputs.outputs[index], 255.0, clamp=True)
        low = b.math("DIVIDE", encoded, 12.92)
        high = b.math("POWER", b.math("DIVIDE", b.math("ADD", encoded, 0.055), 1.055), 2.4)
        is_low = b.math("LESS_THAN", encoded, 0.04045)
        mix = b.node("Mix", data_type="FLOAT")
        b.link(is_low, mix.inputs["Factor"])
        b.link(high, mix.inputs["A"])
        b.link(low, mix.inputs["B"])
        b.link(mix.outputs["Result"], combine.inputs[index])
    b.link(combine.outputs[0], b.node("NodeGroupOutput").inputs[0])


def srgb_group() -> bpy.types.NodeTree:
    """Get or create the sRGB [0,255] -> linear colour helper group."""
    return get_or_create_group(SRGB_GROUP_NAME, SHADER_TREE, _build_srgb)


def _build_lipstick(group: bpy.types.NodeTree) -> None:
    spec = get_spec("lipstick")
    group.interface.new_socket("Lips", in_out="INPUT", socket_type="NodeSocketShader").description = (
        "The lips' own shader, seen where the makeup is transparent"
    )
    add_spec_inputs(group, spec.params)
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    b = Builder(group, "Shader")
    gin = b.node("NodeGroupInput").outputs
    srgb = srgb_group()

    colour = b.group_node(srgb, "Makeup Colour")
    for index, name in enumerate(("Red", "Green", "Blue")):
        b.link(gin[name], colour.inputs[index])
    sparkle_colour = b.group_node(srgb, "Sparkle Colour")
    for index, name in enumerate(("Sparkle Red", "Sparkle Green", "Sparkle Blue")):
        b.link(gin[name], sparkle_colour.inputs[index])

    # Lip line: darken the band next to the outer contour (UV v = 0 there, 1 at the mouth line). A mesh without
    # a UV map reads UV (0, 0) everywhere; the band is then switched off instead of darkening the whole mesh.
    uv = b.node("UVMap")
    uv_parts = b.node("SeparateXYZ")
    b.link(uv.outputs["UV"], uv_parts.inputs[0])
    has_uv = b.math("GREATER_THAN", b.math("ADD", uv_parts.outputs["X"], uv_parts.outputs["Y"]), 1e-6)
    edge = b.node("MapRange", interpolation_type="SMOOTHSTEP", label="Lip Line Band")
    b.link(uv_parts.outputs["Y"], edge.inputs["Value"])
    b.link(LIP_LINE_WIDTH, edge.inputs["From Max"])
    b.link(1.0, edge.inputs["To Min"])
    b.link(0.0, edge.inputs["To Max"])
    band = b.math("MULTIPLY", edge.outputs[0], has_uv)
    darkening = b.math("SUBTRACT", 1.0, b.math("MULTIPLY", b.math("MULTIPLY", band, gin["Lip Line"]), LIP_LINE_DARKENING))
    base_colour = b.node("Mix", data_type="RGBA", blend_type="MULTIPLY", label="Lip Line")
    b.link(1.0, base_colour.inputs["Factor"])
    b.link(colour.outputs[0], base_colour.inputs[6])
    grey = b.node("CombineColor")
    for index in range(3):
        b.link(darkening, grey.inputs[index])
    b.link(grey.outputs[0], base_colour.inputs[7])

    # Creamy texture: a noise bump in object space shared by every layer.
    coords = b.node("TexCoord")
    noise = b.node("TexNoise", label="Texture Noise")
    b.link(coords.outputs["Object"], noise.inputs["Vector"])
    b.link(TEXTURE_SCALE, noise.inputs["Scale"])
    bump = b.node("Bump")
    b.link(b.math("MULTIPLY", gin["Texture"], TEXTURE_BUMP_STRENGTH), bump.inputs["Strength"])
    b.link(0.05, bump.inputs["Distance"])
    b.link(noise.outputs["Fac"], bump.inputs["Height"])
    normal = bump.outputs["Normal"]

    # Base and gloss in one energy-conserving Principled BSDF: the gloss is its Coat, which dims what lies below
    # by the light it reflects, so a glossy colour stays that colour under the highlights.
    base = b.node("BsdfPrincipled", label="Makeup Base + Gloss Coat")
    b.link(base_colour.outputs[2], base.inputs["Base Color"])
    b.link(gin["Metallic"], base.inputs["Metallic"])
    b.link(BASE_ROUGHNESS, base.inputs["Roughness"])
    b.link(gin["Sheen"], base.inputs["Sheen Weight"])
    b.link(normal, base.inputs["Normal"])
    gloss = b.math("MAXIMUM", gin["Gloss"], 0.0)
    root_f0 = b.math("SQRT", b.math("MULTIPLY", b.math("DIVIDE", gloss, b.math("ADD", gloss, 1.0)), GLOSS_F0_MAX))
    b.link(1.0, base.inputs["Coat Weight"])
    b.link(b.math("DIVIDE", b.math("ADD", 1.0, root_f0), b.math("SUBTRACT", 1.0, root_f0)), base.inputs["Coat IOR"])
    b.link(gin["Gloss Roughness"], base.inputs["Coat Roughness"])
    b.link(normal, base.inputs["Coat Normal"])

    # Reflection: a sharp mirror mixed in (a convex mix, so energy is kept) by Reflection x Fresnel.
    fresnel = b.node("Fresnel")
    b.link(REFLECTION_IOR, fresnel.inputs["IOR"])
    b.link(normal, fresnel.inputs["Normal"])
    reflection = b.node("BsdfGlossy", label="Reflection")
    b.link(REFLECTION_ROUGHNESS, reflection.inputs["Roughness"])
    b.link(normal, reflection.inputs["Normal"])
    with_reflection = b.node("MixShader", label="Reflection Mix")
    b.link(b.math("MULTIPLY", gin["Reflection"], fresnel.outputs[0]), with_reflection.inputs["Fac"])
    b.link(base.outputs[0], with_reflection.inputs[1])
    b.link(reflection.outputs[0], with_reflection.inputs[2])

    # Sparkles: Voronoi cells on the object's xy plane (the lips face +z); a cell holds a flake when its random value < density; a flake
    # replaces the layer under it by a tilted coloured mirror, weighted by intensity (a convex mix again).
    cells = b.node("TexVoronoi", label="Sparkle Cells", voronoi_dimensions="2D")  # 3D cells: the surface misses most
    b.link(coords.outputs["Object"], cells.inputs["Vector"])
    b.link(SPARKLE_CELLS_PER_UNIT, cells.inputs["Scale"])
    radius = b.node("MapRange", label="Sparkle Radius")
    b.link(gin["Sparkle Size"], radius.inputs["Value"])
    b.link(SPARKLE_RADIUS_MIN, radius.inputs["To Min"])
    b.link(SPARKLE_RADIUS_MAX, radius.inputs["To Max"])
    cell_random = b.node("SeparateColor")
    b.link(cells.outputs["Color"], cell_random.inputs[0])
    is_flake = b.math("MULTIPLY", b.math("LESS_THAN", cell_random.outputs[0], gin["Sparkle Density"]),
                      b.math("LESS_THAN", cells.outputs["Distance"], radius.outputs[0]))
    flake_weight = b.math("MULTIPLY", is_flake, gin["Sparkle Intensity"], clamp=True)
    tilt = b.node("VectorMath", operation="MULTIPLY_ADD")
    b.link(cells.outputs["Color"], tilt.inputs[0])
    b.link((1.2, 1.2, 1.2), tilt.inputs[1])
    b.link((-0.6, -0.6, -0.6), tilt.inputs[2])
    tilted = b.node("VectorMath", operation="ADD")
    b.link(normal, tilted.inputs[0])
    b.link(tilt.outputs[0], tilted.inputs[1])
    flake_normal = b.node("VectorMath", operation="NORMALIZE")
    b.link(tilted.outputs[0], flake_normal.inputs[0])
    sparkle = b.node("BsdfGlossy", label="Sparkle")
    b.link(sparkle_colour.outputs[0], sparkle.inputs["Color"])
    b.link(SPARKLE_ROUGHNESS, sparkle.inputs["Roughness"])
    b.link(flake_normal.outputs[0], sparkle.inputs["Normal"])
    with_sparkles = b.node("MixShader", label="Sparkle Mix")
    b.link(flake_weight, with_sparkles.inputs["Fac"])
    b.link(with_reflection.outputs[0], with_sparkles.inputs[1])
    b.link(sparkle.outputs[0], with_sparkles.inputs[2])

    over_lips = b.node("MixShader", label="Opacity")
    b.link(gin["Opacity"], over_lips.inputs["Fac"])
    b.link(gin["Lips"], over_lips.inputs[1])
    b.link(with_sparkles.outputs[0], over_lips.inputs[2])
    b.link(over_lips.outputs[0], b.node("NodeGroupOutput").inputs[0])


def lipstick_group() -> bpy.types.NodeTree:
    """Get or create the "VTO Lipstick" shader group (all 17 spec inputs plus the Lips shader)."""
    return get_or_create_group(GROUP_NAME, SHADER_TREE, _build_lipstick)


def lipstick_material(name: str, values: dict[str, float] | None = None) -> bpy.types.Material:
    """A new material: a Principled BSDF "Bare Lips" -> the "VTO Lipstick" group (inputs set from `values`, checked
    against the spec; the others at the group's defaults) -> Material Output."""
    return layer_material(name, lipstick_group(), get_spec("lipstick"), "Bare Lips", (0.45, 0.16, 0.14, 1.0), 0.45,
                          values)
