"""Compositor groups of the hair stage: "VTO Hair Swatch" (pass 1) and "VTO Hair Color" (pass 2)."""

from __future__ import annotations

import bpy

from vto_core.hair import BLEND_OFFSET, BLEND_RAMP, BLEND_SCALE, GLOBAL_CONTRAST_GAIN, LOCAL_CONTRAST_GAIN
from vto_core.products import get_spec

from ..compat import COMPOSITOR_TREE, mix_color_sockets, set_blur_size, set_gaussian_blur
from .node_utils import Builder, add_spec_inputs, get_or_create_group

SWATCH_GROUP = "VTO Hair Swatch"
COLOR_GROUP = "VTO Hair Color"
FIT_COLOR_GROUP = "VTO Hair Fit Color"  # the internal passes' copy: a fit never sets the curve of an artist's stage
LUT_NODE = "Histogram LUT"
BLUR_NODE = "Local Contrast Blur"


def _params(group_name: str):
    return [p for p in get_spec("hair").params if p.group == group_name]


def _per_channel(b: Builder, image, channel_fn):
    """Separate an image, run channel_fn(socket) -> socket on R, G and B, combine again."""
    split = b.node("SeparateColor")
    b.link(image, split.inputs[0])
    join = b.node("CombineColor")
    for index in range(3):
        b.link(channel_fn(split.outputs[index]), join.inputs[index])
    return join.outputs[0]


def _build_swatch(group: bpy.types.NodeTree) -> None:
    """Brightness/contrast, exposure, clamp, gamma, hue shift, saturation, clamp (vto_core.colour.recolour_swatch)."""
    group.interface.new_socket("Image", in_out="INPUT", socket_type="NodeSocketColor")
    add_spec_inputs(group, _params("swatch"))
    group.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    b = Builder(group, "Compositor")
    gin = b.node("NodeGroupInput").outputs
    inverse_gamma = b.math("DIVIDE", 1.0, gin["Gamma"])

    def tone(x):
        y = b.math("ADD", b.math("MULTIPLY", b.math("SUBTRACT", x, 0.5), gin["Contrast"]), 0.5)
        y = b.math("MULTIPLY", b.math("ADD", y, gin["Brightness"]), gin["Exposure"], clamp=True)
        return b.math("POWER", y, inverse_gamma)

    toned = _per_channel(b, gin["Image"], tone)
    hsv = b.node("HueSat", label="Hue / Saturation")
    b.link(toned, hsv.inputs["Image"])
    # The node shifts hue by (input - 0.5); feeding frac(hue + 0.5) shifts it by hue, wrapping.
    b.link(b.math("FRACT", b.math("ADD", gin["Hue"], 0.5)), hsv.inputs["Hue"])
    b.link(gin["Saturation"], hsv.inputs["Saturation"])
    clamped = _per_channel(b, hsv.outputs[0], lambda x: b.math("MULTIPLY", x, 1.0, clamp=True))
    b.link(clamped, b.node("NodeGroupOutput").inputs[0])


def _build_color(group: bpy.types.NodeTree) -> None:
    """Histogram-matching curves, shine, then mix into the source by mask * faded-look weight * intensity."""
    for name, kind in (("Image", "NodeSocketColor"), ("Mask", "NodeSocketFloat"), ("Gradient", "NodeSocketFloat")):
        group.interface.new_socket(name, in_out="INPUT", socket_type=kind)
    add_spec_inputs(group, _params("non-swatch"))
    group.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    b = Builder(group, "Compositor")
    gin = b.node("NodeGroupInput").outputs
    lut = b.node("CurveRGB", label="Histogram LUT (set per render)")
    lut.name = LUT_NODE
    b.link(gin["Image"], lut.inputs["Image"])

    # Shine: global contrast (S-curve) plus local contrast (unsharp mask; the blur's size is set per render).
    blur = b.node("Blur", label="Local Contrast Blur (size set per render)")
    blur.name = BLUR_NODE
    set_gaussian_blur(blur)
    b.link(lut.outputs[0], blur.inputs["Image"])
    curved, blurred = b.node("SeparateColor"), b.node("SeparateColor")
    b.link(lut.outputs[0], curved.inputs[0])
    b.link(blur.outputs[0], blurred.inputs[0])
    shined = b.node("CombineColor")
    for index in range(3):
        y = b.math("MULTIPLY", curved.outputs[index], 1.0, clamp=True)
        smooth = b.math("MULTIPLY", b.math("MULTIPLY", y, y), b.math("SUBTRACT", 3.0, b.math("MULTIPLY", y, 2.0)))
        curve = b.math("MULTIPLY", b.math("SUBTRACT", smooth, y), GLOBAL_CONTRAST_GAIN)
        local = b.math("MULTIPLY", b.math("SUBTRACT", y, blurred.outputs[index]), LOCAL_CONTRAST_GAIN)
        boost = b.math("MULTIPLY", b.math("ADD", curve, local), gin["Shine"])
        b.link(b.math("ADD", y, boost, clamp=True), shined.inputs[index])
    offset = b.math("ADD", b.math("MULTIPLY", gin["Blend"], BLEND_SCALE), BLEND_OFFSET)
    weight = b.math("MULTIPLY", b.math("SUBTRACT", gin["Gradient"], offset), BLEND_RAMP, clamp=True)
    mask = b.math("MULTIPLY", gin["Mask"], 1.0, clamp=True)
    alpha = b.math("MULTIPLY", b.math("MULTIPLY", mask, weight), gin["Intensity"])
    factor, first, second, result = mix_color_sockets(b.node("MixRGB", label="Intensity"))
    b.link(alpha, factor)
    b.link(gin["Image"], first)
    b.link(shined.outputs[0], second)
    b.link(result, b.node("NodeGroupOutput").inputs[0])


def swatch_group() -> bpy.types.NodeTree:
    """Get or create the pass-1 compositor group (swatch recolouring)."""
    return get_or_create_group(SWATCH_GROUP, COMPOSITOR_TREE, _build_swatch)


def color_group(name: str = COLOR_GROUP) -> bpy.types.NodeTree:
    """Get or create the pass-2 compositor group (LUT, shine, faded look, intensity): the artist's stages'
    (COLOR_GROUP), or the internal passes' (FIT_COLOR_GROUP)."""
    return get_or_create_group(name, COMPOSITOR_TREE, _build_color)


def set_blur_radius(group: bpy.types.NodeTree, radius: int) -> None:
    """Set the local-contrast blur's radius in pixels (vto_core.hair.blur_radius of the image width)."""
    set_blur_size(group.nodes[BLUR_NODE], radius)


def set_lut(group: bpy.types.NodeTree, gray_lut, channel_luts) -> None:
    """Write the matching LUTs into the group's RGB Curves: C = gray LUT, then R, G, B (vector handles)."""
    mapping = group.nodes[LUT_NODE].mapping
    for curve, (xs, ys) in zip((mapping.curves[3], *mapping.curves[:3]), (gray_lut, *channel_luts)):
        points = curve.points
        while len(points) > max(len(xs), 2):
            points.remove(points[-1])
        while len(points) < len(xs):
            points.new(0.5, 0.5)
        for point, x, y in zip(points, xs, ys):
            point.location = (float(x), float(y))
            point.handle_type = "VECTOR"
    mapping.update()
