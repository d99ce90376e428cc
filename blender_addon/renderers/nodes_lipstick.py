"""The "VTO Lipstick" shader node group: a makeup layer mixed over the lips' own shader by opacity."""

from __future__ import annotations

from vto_core.products import get_spec

from .face_layer import LayerGroup, layer_colours, sparkle_flakes
from .node_utils import Builder

GROUP_NAME = "VTO Lipstick"

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
LIP_LINE_WIDTH = 0.25  # in UV v, from the outer contour
LIP_LINE_DARKENING = 0.75
TEXTURE_SCALE = 9.0  # noise features of about 3 px at 64 px on the default lips
TEXTURE_BUMP_STRENGTH = 0.6


def _lipstick_layer(b: Builder, gin):
    """(coverage, the makeup's shader): Opacity, and the base, coat, mirror and flakes over the lips."""
    colour, sparkle_colour = layer_colours(b, gin, "Makeup Colour")

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

    # Sparkles: flakes on the object's xy plane (the lips face +z), tilted from the textured normal; a flake replaces
    # the layer under it, weighted by intensity (a convex mix again).
    flake_weight, sparkle = sparkle_flakes(b, gin, sparkle_colour.outputs[0], normal, SPARKLE_CELLS_PER_UNIT, coords)
    with_sparkles = b.node("MixShader", label="Sparkle Mix")
    b.link(flake_weight, with_sparkles.inputs["Fac"])
    b.link(with_reflection.outputs[0], with_sparkles.inputs[1])
    b.link(sparkle, with_sparkles.inputs[2])
    return gin["Opacity"], with_sparkles.outputs[0]


# The "VTO Lipstick" group: the Lips shader, all 17 spec inputs.
LIPSTICK_GROUP = LayerGroup(GROUP_NAME, lambda: get_spec("lipstick"), "Lips",
                            "The lips' own shader, seen where the makeup is transparent", _lipstick_layer, None,
                            "Opacity", "Bare Lips", (0.45, 0.16, 0.14, 1.0), 0.45)
lipstick_group, lipstick_material = LIPSTICK_GROUP.group, LIPSTICK_GROUP.material
