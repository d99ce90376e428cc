"""The "VTO Lipstick" shader node group: a makeup layer mixed over the lips' own shader by opacity."""

from __future__ import annotations

import bpy

from vto_core.specs import get_spec

from .node_utils import Builder, add_spec_inputs, get_or_create_group

GROUP_NAME = "VTO Lipstick"
SRGB_GROUP_NAME = "VTO sRGB 255 to Linear"
SHADER_TREE = "ShaderNodeTree"

# Looks chosen by eye at 64-256 px; gloss is unbounded, so its layer colour is gloss * GLOSS_GAIN.
BASE_ROUGHNESS = 0.55
GLOSS_GAIN = 0.12
REFLECTION_ROUGHNESS = 0.03
SPARKLE_CELLS = 150.0  # flake positions stay put as the size changes, so size grows flakes in place
SPARKLE_RADIUS_MIN, SPARKLE_RADIUS_MAX = 0.1, 0.5  # flake radius in cell units over Sparkle Size [0, 1]
SPARKLE_GAIN = 3.0
LIP_LINE_WIDTH = 0.25  # in UV v, from the outer contour
LIP_LINE_DARKENING = 0.75
TEXTURE_BUMP_STRENGTH = 0.4


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

    # Lip line: darken the band next to the outer contour (UV v = 0 there, 1 at the mouth line).
    uv = b.node("UVMap")
    v_coord = b.node("SeparateXYZ")
    b.link(uv.outputs["UV"], v_coord.inputs[0])
    edge = b.node("MapRange", interpolation_type="SMOOTHSTEP", label="Lip Line Band")
    b.link(v_coord.outputs["Y"], edge.inputs["Value"])
    b.link(LIP_LINE_WIDTH, edge.inputs["From Max"])
    b.link(1.0, edge.inputs["To Min"])
    b.link(0.0, edge.inputs["To Max"])
    darkening = b.math("SUBTRACT", 1.0, b.math("MULTIPLY", b.math("MULTIPLY", edge.outputs[0], gin["Lip Line"]), LIP_LINE_DARKENING))
    base_colour = b.node("Mix", data_type="RGBA", blend_type="MULTIPLY", label="Lip Line")
    b.link(1.0, base_colour.inputs["Factor"])
    b.link(colour.outputs[0], base_colour.inputs[6])
    grey = b.node("CombineColor")
    for index in range(3):
        b.link(darkening, grey.inputs[index])
    b.link(grey.outputs[0], base_colour.inputs[7])

    # Creamy texture: a fine noise bump shared by every layer.
    noise = b.node("TexNoise", label="Texture Noise")
    b.link(120.0, noise.inputs["Scale"])
    bump = b.node("Bump")
    b.link(b.math("MULTIPLY", gin["Texture"], TEXTURE_BUMP_STRENGTH), bump.inputs["Strength"])
    b.link(0.02, bump.inputs["Distance"])
    b.link(noise.outputs["Fac"], bump.inputs["Height"])
    normal = bump.outputs["Normal"]

    base = b.node("BsdfPrincipled", label="Makeup Base")
    b.link(base_colour.outputs[2], base.inputs["Base Color"])
    b.link(gin["Metallic"], base.inputs["Metallic"])
    b.link(BASE_ROUGHNESS, base.inputs["Roughness"])
    b.link(gin["Sheen"], base.inputs["Sheen Weight"])
    b.link(normal, base.inputs["Normal"])

    gloss_level = b.math("MULTIPLY", gin["Gloss"], GLOSS_GAIN)
    gloss_colour = b.node("CombineColor")
    for index in range(3):
        b.link(gloss_level, gloss_colour.inputs[index])
    gloss = b.node("BsdfGlossy", label="Gloss")
    b.link(gloss_colour.outputs[0], gloss.inputs["Color"])
    b.link(gin["Gloss Roughness"], gloss.inputs["Roughness"])
    b.link(normal, gloss.inputs["Normal"])

    reflection_colour = b.node("CombineColor")
    for index in range(3):
        b.link(gin["Reflection"], reflection_colour.inputs[index])
    reflection = b.node("BsdfGlossy", label="Reflection")
    b.link(reflection_colour.outputs[0], reflection.inputs["Color"])
    b.link(REFLECTION_ROUGHNESS, reflection.inputs["Roughness"])
    b.link(normal, reflection.inputs["Normal"])

    # Sparkles: Voronoi cells; a cell is a flake when its random value < density; flakes tilt their normal.
    coords = b.node("TexCoord")
    cells = b.node("TexVoronoi", label="Sparkle Cells")
    b.link(coords.outputs["Object"], cells.inputs["Vector"])
    b.link(SPARKLE_CELLS, cells.inputs["Scale"])
    radius = b.node("MapRange", label="Sparkle Radius")
    b.link(gin["Sparkle Size"], radius.inputs["Value"])
    b.link(SPARKLE_RADIUS_MIN, radius.inputs["To Min"])
    b.link(SPARKLE_RADIUS_MAX, radius.inputs["To Max"])
    cell_random = b.node("SeparateColor")
    b.link(cells.outputs["Color"], cell_random.inputs[0])
    is_flake = b.math("MULTIPLY", b.math("LESS_THAN", cell_random.outputs[0], gin["Sparkle Density"]),
                      b.math("LESS_THAN", cells.outputs["Distance"], radius.outputs[0]))
    flake_level = b.math("MULTIPLY", b.math("MULTIPLY", is_flake, gin["Sparkle Intensity"]), SPARKLE_GAIN)
    flake_colour = b.node("VectorMath", operation="SCALE")
    b.link(sparkle_colour.outputs[0], flake_colour.inputs[0])
    b.link(flake_level, flake_colour.inputs["Scale"])
    tilt = b.node("VectorMath", operation="MULTIPLY_ADD")
    b.link(cells.outputs["Color"], tilt.inputs[0])
    b.link((1.5, 1.5, 1.5), tilt.inputs[1])
    b.link((-0.75, -0.75, -0.75), tilt.inputs[2])
    tilted = b.node("VectorMath", operation="ADD")
    b.link(normal, tilted.inputs[0])
    b.link(tilt.outputs[0], tilted.inputs[1])
    flake_normal = b.node("VectorMath", operation="NORMALIZE")
    b.link(tilted.outputs[0], flake_normal.inputs[0])
    sparkle = b.node("BsdfGlossy", label="Sparkle")
    b.link(flake_colour.outputs[0], sparkle.inputs["Color"])
    b.link(0.08, sparkle.inputs["Roughness"])
    b.link(flake_normal.outputs[0], sparkle.inputs["Normal"])

    layers = base.outputs[0]
    for layer in (gloss, reflection, sparkle):
        add = b.node("AddShader")
        b.link(layers, add.inputs[0])
        b.link(layer.outputs[0], add.inputs[1])
        layers = add.outputs[0]

    over_lips = b.node("MixShader", label="Opacity")
    b.link(gin["Opacity"], over_lips.inputs["Fac"])
    b.link(gin["Lips"], over_lips.inputs[1])
    b.link(layers, over_lips.inputs[2])
    b.link(over_lips.outputs[0], b.node("NodeGroupOutput").inputs[0])


def lipstick_group() -> bpy.types.NodeTree:
    """Get or create the "VTO Lipstick" shader group (all 17 spec inputs plus the Lips shader)."""
    return get_or_create_group(GROUP_NAME, SHADER_TREE, _build_lipstick)
