"""The "VTO Eye Shadow" shader node group: a shadow layer mixed over the lid's own shader by its coverage of the lid."""

from __future__ import annotations

import bpy

from vto_core.products import get_spec

from .face_layer import LayerGroup, layer_colours, sparkle_flakes
from .node_utils import Builder

GROUP_NAME = "VTO Eye Shadow"
LID_ATTRIBUTE = "vto_lid"  # 0 at the lash line, 1 at the brow's lower edge
ACROSS_ATTRIBUTE = "vto_lid_u"  # along the lid: -1 at the inner end, 1 at the outer end (0 on a mesh without it)

# Looks chosen by eye at 64-160 px on the default eye scene: pressed pigment is never a mirror, even as foil.
MATTE_ROUGHNESS, METAL_ROUGHNESS = 0.75, 0.55  # the base's roughness at Metallic 0 and 1: a foil is smoother
SHIMMER_SHARE = 0.6  # the share of the shadow a Shimmer of 1 makes pearl: the rest keeps the shadow's colour
SHIMMER_ROUGHNESS_MIN, SHIMMER_ROUGHNESS_MAX = 0.25, 0.8  # over Shimmer Roughness [0, 1]
# Height's edge fades over this much lid coordinate at Softness 0 and 1: never 0, so the band stays a smooth function.
EDGE_MIN, EDGE_MAX = 0.02, 0.62
END_MIN, END_MAX = 0.15, 0.65  # the share of the lid's half length over which the shadow fades out at its two ends
# Sparkle flakes live in the object's own space, sized so that a flake covers about a pixel at the 64 px training
# size on the default eye (2 units across the frame): smaller flakes are invisible to an encoder.
SPARKLE_CELLS_PER_UNIT = 16.0


def _affine(b: Builder, value, scale: float, offset: float):
    """value x scale + offset (a Multiply Add node); returns its output socket."""
    node = b.node("Math", operation="MULTIPLY_ADD")
    b.link(value, node.inputs[0])
    b.link(scale, node.inputs[1])
    b.link(offset, node.inputs[2])
    return node.outputs[0]


def _lid_input(b: Builder, given, attribute: str, low: float):
    """The coordinate an input gives where it is at least `low`, else the mesh's named `attribute`."""
    read = b.node("Attribute", label=f"Attribute {attribute}", attribute_name=attribute)
    given_is_set = b.math("GREATER_THAN", given, low - 1e-6)
    choose = b.node("Mix", data_type="FLOAT", label=f"{attribute} or input")
    b.link(given_is_set, choose.inputs["Factor"])
    b.link(read.outputs["Fac"], choose.inputs["A"])
    b.link(given, choose.inputs["B"])
    return choose.outputs["Result"]


def _coverage(b: Builder, gin):
    """Opacity x the band from the lash line to Height (fading over Softness) x the weight along the lid (Shift, and
    the fade at its ends)."""
    lid = _lid_input(b, gin["Lid Coordinate"], LID_ATTRIBUTE, 0.0)
    across = _lid_input(b, gin["Lid Across"], ACROSS_ATTRIBUTE, -1.0)
    width = _affine(b, gin["Softness"], EDGE_MAX - EDGE_MIN, EDGE_MIN)
    start = b.math("MULTIPLY", gin["Height"], b.math("SUBTRACT", 1.0, width))  # the fade ends at Height 1 by the brow
    band = b.node("MapRange", interpolation_type="SMOOTHSTEP", label="Height Band")
    b.link(lid, band.inputs["Value"])
    b.link(start, band.inputs["From Min"])
    b.link(b.math("ADD", start, width), band.inputs["From Max"])
    b.link(1.0, band.inputs["To Min"])
    b.link(0.0, band.inputs["To Max"])

    shifted = b.node("MapRange", interpolation_type="SMOOTHSTEP", label="Shift")  # 1 + Shift x across, in [0, 1]
    b.link(b.math("MULTIPLY", gin["Shift"], across), shifted.inputs["Value"])
    b.link(-1.0, shifted.inputs["From Min"])
    b.link(0.0, shifted.inputs["From Max"])
    end_width = _affine(b, gin["Softness"], END_MAX - END_MIN, END_MIN)
    ends = b.node("MapRange", interpolation_type="SMOOTHSTEP", label="Lid Ends")
    b.link(b.math("ABSOLUTE", across), ends.inputs["Value"])
    b.link(b.math("SUBTRACT", 1.0, end_width), ends.inputs["From Min"])
    b.link(1.0, ends.inputs["From Max"])
    b.link(1.0, ends.inputs["To Min"])
    b.link(0.0, ends.inputs["To Max"])
    along = b.math("MULTIPLY", shifted.outputs[0], ends.outputs[0])
    return b.math("MULTIPLY", b.math("MULTIPLY", band.outputs[0], along), gin["Opacity"], clamp=True)


def _lid_inputs(group: bpy.types.NodeTree) -> None:
    """The lid coordinates' inputs, after the spec's: each overrides the mesh's attribute where it is set."""
    lid = group.interface.new_socket("Lid Coordinate", in_out="INPUT", socket_type="NodeSocketFloat")
    lid.default_value, lid.min_value, lid.max_value = -1.0, -1.0, 1.0
    lid.description = (f"Where a point lies between the lash line (0) and the brow (1). Below 0 (the default): the "
                       f"mesh's '{LID_ATTRIBUTE}' attribute, which a mesh without it reads as 0 (the shadow "
                       "everywhere); link a painted or computed value to override it")
    across = group.interface.new_socket("Lid Across", in_out="INPUT", socket_type="NodeSocketFloat")
    across.default_value, across.min_value, across.max_value = -2.0, -2.0, 1.0
    across.description = (f"Where a point lies along the lid, -1 at the inner end to 1 at the outer end (Shift "
                          f"weighs it). Below -1 (the default): the mesh's '{ACROSS_ATTRIBUTE}' attribute, 0 on a "
                          "mesh without it (even, no fade at the ends)")


def _eyeshadow_layer(b: Builder, gin):
    """(coverage, the shadow's shader): the band on the lid (_coverage), and the pigment, shimmer and flakes."""
    colour, sparkle_colour = layer_colours(b, gin, "Shadow Colour")

    # Matte or metallic base: one Principled BSDF, its roughness falling with Metallic (pressed foil is smoother).
    base = b.node("BsdfPrincipled", label="Shadow Base")
    b.link(colour.outputs[0], base.inputs["Base Color"])
    b.link(gin["Metallic"], base.inputs["Metallic"])
    b.link(_affine(b, gin["Metallic"], METAL_ROUGHNESS - MATTE_ROUGHNESS, MATTE_ROUGHNESS),
           base.inputs["Roughness"])

    # Shimmer: pearl pigment, a tinted metallic reflector mixed in (a convex mix, so energy is kept) by Shimmer.
    tint = b.node("Mix", data_type="RGBA", label="Shimmer Tint")
    b.link(gin["Shimmer Tint"], tint.inputs["Factor"])
    b.link((1.0, 1.0, 1.0, 1.0), tint.inputs[6])
    b.link(colour.outputs[0], tint.inputs[7])
    pearl = b.node("BsdfPrincipled", label="Shimmer")
    b.link(tint.outputs[2], pearl.inputs["Base Color"])
    b.link(1.0, pearl.inputs["Metallic"])
    b.link(_affine(b, gin["Shimmer Roughness"], SHIMMER_ROUGHNESS_MAX - SHIMMER_ROUGHNESS_MIN,
                  SHIMMER_ROUGHNESS_MIN), pearl.inputs["Roughness"])
    with_shimmer = b.node("MixShader", label="Shimmer Mix")
    b.link(b.math("MULTIPLY", gin["Shimmer"], SHIMMER_SHARE, clamp=True), with_shimmer.inputs["Fac"])
    b.link(base.outputs[0], with_shimmer.inputs[1])
    b.link(pearl.outputs[0], with_shimmer.inputs[2])

    flake_weight, sparkle = sparkle_flakes(b, gin, sparkle_colour.outputs[0], b.node("NewGeometry").outputs["Normal"],
                                           SPARKLE_CELLS_PER_UNIT)
    with_sparkles = b.node("MixShader", label="Sparkle Mix")
    b.link(flake_weight, with_sparkles.inputs["Fac"])
    b.link(with_shimmer.outputs[0], with_sparkles.inputs[1])
    b.link(sparkle, with_sparkles.inputs[2])

    return _coverage(b, gin), with_sparkles.outputs[0]


# The "VTO Eye Shadow" group: the Lid shader, all 17 spec inputs, the lid coordinates.
EYESHADOW_GROUP = LayerGroup(GROUP_NAME, lambda: get_spec("eyeshadow"), "Lid",
                             "The lid's own shader, seen where the shadow is transparent or does not reach",
                             _eyeshadow_layer, _lid_inputs, "Coverage", "Bare Lid", (0.52, 0.33, 0.25, 1.0), 0.5)
eyeshadow_group, eyeshadow_material = EYESHADOW_GROUP.group, EYESHADOW_GROUP.material
