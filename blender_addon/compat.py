"""Every difference between the Blender versions the add-on supports (4.2 LTS to 5.x), and only here."""

from __future__ import annotations

import bpy

# 5.0 made the compositor a node group (scene.compositing_node_group with a Group Output instead of a Composite
# node), dropped the compositor's own Math and Mix nodes for the shader ones, turned node options such as the
# Blur type into input sockets, and moved multilayer EXR from file_format to media_type.
BLENDER_5 = bpy.app.version >= (5, 0, 0)
COMPOSITOR_IS_GROUP = BLENDER_5
COMPOSITOR_TREE = "CompositorNodeTree"
# 5.0 gives every material and world a node tree (use_nodes is deprecated) and renamed EEVEE Next back to EEVEE.
NODES_ALWAYS_ON = BLENDER_5
EEVEE_ENGINE = "BLENDER_EEVEE" if BLENDER_5 else "BLENDER_EEVEE_NEXT"
OUTPUT_SOCKET = "Image"  # the Composite node's input, or the compositing group's output socket

# What saves an image's format, in the order to restore it (the media type limits the file formats).
HAS_MEDIA_TYPE = "media_type" in bpy.types.ImageFormatSettings.bl_rna.properties
IMAGE_FORMAT_FIELDS = ("media_type", "file_format") if HAS_MEDIA_TYPE else ("file_format",)

# Render pass names that 5.0 spelt out, to the names the add-on reads.
_PASS_NAMES = {"Object Index": "IndexOB", "Material Index": "IndexMA"}

# Compositor node kinds (Builder's short names) that 5.0 replaced with the shader node of another kind.
_COMPOSITOR_RENAMED = {"Math": "ShaderNodeMath", "MixRGB": "ShaderNodeMix", "Gamma": "ShaderNodeGamma"} \
    if COMPOSITOR_IS_GROUP else {}


def canonical_pass_name(name: str) -> str:
    """A render pass's name as Blender 4.x writes it into an EXR ("IndexOB" for 5.0's "Object Index")."""
    return _PASS_NAMES.get(name, name)


def render_layer_output(node, pass_name: str):
    """The Render Layers node's output of pass `pass_name` as 4.x names it ("IndexOB"), in this Blender."""
    spelt = {canonical: full for full, canonical in _PASS_NAMES.items()}.get(pass_name, pass_name)
    name = spelt if BLENDER_5 else pass_name
    # by name, not by key: a pass turned on just now is not yet available to the key lookup
    return next(output for output in node.outputs if output.name == name)


def set_id_mask(node, index: int, antialias: bool = True) -> None:
    """Set an ID Mask node's index and anti-aliasing (node properties before 5.0, input sockets since)."""
    if "Index" in node.inputs:
        node.inputs["Index"].default_value = index
        node.inputs["Anti-Alias"].default_value = antialias
    if hasattr(node, "index"):
        node.index, node.use_antialiasing = index, antialias


def id_mask_index(node) -> int:
    """An ID Mask node's index (a node property before 5.0, an input socket since)."""
    return int(node.inputs["Index"].default_value if "Index" in node.inputs else node.index)


def compositor_idname(kind: str) -> str:
    """The bl_idname of compositor node kind `kind` ("Math", "Blur", ...) in this Blender."""
    return _COMPOSITOR_RENAMED.get(kind, "CompositorNode" + kind)


def compositor_tree(scene: bpy.types.Scene, create: bool = False) -> bpy.types.NodeTree | None:
    """The compositor node tree of `scene`; with create, make (and enable) one when it has none."""
    if scene is None:
        return None
    if not COMPOSITOR_IS_GROUP:
        if create:
            scene.use_nodes = True
        return scene.node_tree
    tree = scene.compositing_node_group
    if tree is None and create:
        tree = bpy.data.node_groups.new(f"{scene.name} Compositing", COMPOSITOR_TREE)
        scene.compositing_node_group = tree
    return tree


def composite_output(tree: bpy.types.NodeTree):
    """The input socket whose image the render writes: the Composite node's, or the group output's (made if
    missing)."""
    if not COMPOSITOR_IS_GROUP:
        node = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeComposite"), None)
        node = node or tree.nodes.new("CompositorNodeComposite")
        return node.inputs[OUTPUT_SOCKET]
    if not any(i.item_type == "SOCKET" and i.in_out == "OUTPUT" for i in tree.interface.items_tree):
        tree.interface.new_socket(OUTPUT_SOCKET, in_out="OUTPUT", socket_type="NodeSocketColor")
    node = next((n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"), None) or tree.nodes.new("NodeGroupOutput")
    node.is_active_output = True
    return node.inputs[0]


def mix_color_sockets(node) -> tuple:
    """(factor, first colour, second colour, result) sockets of a node made as compositor_idname("MixRGB")."""
    if node.bl_idname == "ShaderNodeMix":
        node.data_type = "RGBA"
        return node.inputs["Factor"], node.inputs[6], node.inputs[7], node.outputs[2]
    return node.inputs[0], node.inputs[1], node.inputs[2], node.outputs[0]


def set_gaussian_blur(node) -> None:
    """Make a compositor Blur node Gaussian (a property before 5.0, a menu input since)."""
    if "Type" in node.inputs:
        node.inputs["Type"].default_value = "Gaussian"
    else:
        node.filter_type = "GAUSS"


def set_blur_size(node, pixels: int) -> None:
    """A compositor Blur node's radius in pixels: a two-value 'Size' input since 4.5; before, the size_x and size_y
    properties (and 'Size' a factor on them, kept at 1)."""
    size = node.inputs["Size"]
    if hasattr(size.default_value, "__len__"):
        size.default_value = (pixels, pixels)
    else:
        node.size_x = node.size_y = int(pixels)
        size.default_value = 1.0


def set_exr_output(settings: bpy.types.ImageFormatSettings, multilayer: bool) -> None:
    """Render to a (multilayer) EXR; 5.0 picks multilayer through the media type."""
    if not multilayer:
        set_file_format(settings, "OPEN_EXR")
    elif HAS_MEDIA_TYPE:
        settings.media_type = "MULTI_LAYER_IMAGE"
    else:
        settings.file_format = "OPEN_EXR_MULTILAYER"


def set_file_format(settings: bpy.types.ImageFormatSettings, file_format: str) -> None:
    """Set a single-image file format ("PNG", "OPEN_EXR", ...), whatever the media type was before."""
    if HAS_MEDIA_TYPE:
        settings.media_type = "IMAGE"
    settings.file_format = file_format


def enable_nodes(owner) -> None:
    """Make a material or world render through its node tree (always so since 5.0)."""
    if not NODES_ALWAYS_ON:
        owner.use_nodes = True


def uses_nodes(owner) -> bool:
    """Whether a material or world renders through its node tree."""
    return NODES_ALWAYS_ON or owner.use_nodes
