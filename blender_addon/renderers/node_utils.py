"""Small helpers for node groups: building them (nodes, links, math, interfaces from a spec), finding a group's nodes
in materials, setting their inputs, and a material that layers a group over a bare shader."""

from __future__ import annotations

import bpy

from collections.abc import Iterable

from vto_core.errors import VtoError
from vto_core.specs import ParamSpec, RendererSpec

from ..compat import compositor_idname, compositor_tree, enable_nodes, uses_nodes

# Bumped whenever a builder changes what it builds, so older groups in saved files are rebuilt.
BUILDER_VERSION = 3
VERSION_KEY = "vto_builder_version"
SOCKET_MAX = 3.0e38  # sockets are float32: the top of an unbounded range
SHADER_TREE = "ShaderNodeTree"
SRGB_GROUP_NAME = "VTO sRGB 255 to Linear"


class Builder:
    """Wraps one node tree; lays nodes out left to right as they are added."""

    def __init__(self, tree: bpy.types.NodeTree, prefix: str):
        self.tree = tree
        self.prefix = prefix  # "Shader" or "Compositor": the node type prefix of this tree
        self._column = 0

    def node(self, kind: str, label: str = "", **props):
        """Add a node of type prefix+kind (or a full bl_idname) and set its properties."""
        if kind.startswith(("Shader", "Compositor", "Node")):
            idname = kind
        else:
            idname = compositor_idname(kind) if self.prefix == "Compositor" else self.prefix + "Node" + kind
        node = self.tree.nodes.new(idname)
        for key, value in props.items():
            setattr(node, key, value)
        if label:
            node.label = label
        node.location = (self._column * 200, 0)
        self._column += 1
        return node

    def link(self, source, target) -> None:
        """Connect an output socket to an input socket; a plain number sets the input's value."""
        if isinstance(source, (int, float)):
            target.default_value = source
        elif isinstance(source, (tuple, list)):
            target.default_value = source
        else:
            self.tree.links.new(source, target)

    def math(self, operation: str, a, b=0.0, clamp: bool = False):
        """A Math node computing operation(a, b); returns its output socket."""
        node = self.node("Math", operation=operation, use_clamp=clamp)
        self.link(a, node.inputs[0])
        self.link(b, node.inputs[1])
        return node.outputs[0]

    def group_node(self, group: bpy.types.NodeTree, label: str = ""):
        """Instance of a node group inside this tree."""
        node = self.node(self.prefix + "NodeGroup", label=label or group.name)
        node.node_tree = group
        return node


def get_or_create_group(name: str, tree_type: str, build) -> bpy.types.NodeTree:
    """Return group `name`, (re)building it in place with build(group) if missing or stale.

    Rebuilding in place keeps every material or compositor that already uses the group, the links of its nodes there
    and the input values the artist set on them (where the rebuilt group still has a socket of that name, and for a
    value, of that type).
    """
    group = bpy.data.node_groups.get(name)
    if group is not None and group.bl_idname == tree_type and group.get(VERSION_KEY) == BUILDER_VERSION:
        return group
    if group is None or group.bl_idname != tree_type:
        group = bpy.data.node_groups.new(name, tree_type)
        group.use_fake_user = True  # saved with the .blend even before a material uses it
    kept = [(node, input_values(node), node_links(node)) for node in group_users(group)]
    group.nodes.clear()
    group.interface.clear()  # unlinks and resets every user node's sockets: `kept` puts them back
    build(group)
    group[VERSION_KEY] = BUILDER_VERSION
    for node, values, links in kept:
        set_input_values(node, values)
        relink(node, links)
    return group


def node_links(node: bpy.types.Node) -> list[tuple[bool, str, bpy.types.NodeSocket]]:
    """The links of `node` in its tree: (into it, its socket's name, the other node's socket) each."""
    return [(link.to_node == node, (link.to_socket if link.to_node == node else link.from_socket).name,
             link.from_socket if link.to_node == node else link.to_socket)
            for link in node.id_data.links if node in (link.to_node, link.from_node)]


def relink(node: bpy.types.Node, links: list[tuple[bool, str, bpy.types.NodeSocket]]) -> None:
    """node_links' record linked again where `node` still has a socket of that name."""
    tree = node.id_data
    for into, name, other in links:
        own = (node.inputs if into else node.outputs).get(name)
        if own is not None:
            tree.links.new(*((other, own) if into else (own, other)))


def group_users(group: bpy.types.NodeTree) -> list[bpy.types.Node]:
    """Every node using `group`: in the node trees of materials, worlds and lights, in node groups and in scenes'
    compositors."""
    trees = [owner.node_tree for owner in (*bpy.data.materials, *bpy.data.worlds, *bpy.data.lights)
             if owner.node_tree is not None]
    trees += [*bpy.data.node_groups, *(compositor_tree(scene) for scene in bpy.data.scenes)]
    unique = {tree.as_pointer(): tree for tree in trees if tree is not None}  # a 5.x compositor is a node group too
    return [node for tree in unique.values() for node in tree.nodes if getattr(node, "node_tree", None) == group]


def input_values(node: bpy.types.Node) -> dict[str, tuple[str, object]]:
    """A node's input values by socket name (the first of a name): name -> (socket type, value, arrays copied)."""
    values = {}
    for socket in node.inputs:
        if hasattr(socket, "default_value") and socket.name not in values:
            value = socket.default_value
            values[socket.name] = (socket.type, tuple(value) if isinstance(value, bpy.types.bpy_prop_array) else value)
    return values


def set_input_values(node: bpy.types.Node, values: dict[str, tuple[str, object]]) -> None:
    """Set a group node's inputs from input_values' record (`values`, used up) where an input of that name and type
    is still there, the others to the group's defaults: a node made before the rebuild would read 0 in them."""
    defaults = {item.identifier: item.default_value for item in node.node_tree.interface.items_tree
                if item.item_type == "SOCKET" and item.in_out == "INPUT" and hasattr(item, "default_value")}
    for socket in node.inputs:
        kind, value = values.pop(socket.name, (None, None))
        value = value if kind == socket.type else defaults.get(socket.identifier)
        if value is not None and hasattr(socket, "default_value"):
            try:
                socket.default_value = value
            except (TypeError, ValueError):  # a value the rebuilt input no longer takes (a menu item gone, a size)
                continue


def add_spec_inputs(group: bpy.types.NodeTree, params: Iterable[ParamSpec]) -> None:
    """One float input per parameter: socket name, default, range and tooltip from the spec."""
    for param in params:
        socket = group.interface.new_socket(param.socket, in_out="INPUT", socket_type="NodeSocketFloat")
        socket.default_value = param.default
        socket.min_value = param.low
        socket.max_value = param.high if param.bounded else SOCKET_MAX
        socket.description = param.description


def interface_names(group: bpy.types.NodeTree, in_out: str = "INPUT") -> list[str]:
    """Names of a group's interface sockets of one direction, in order."""
    return [item.name for item in group.interface.items_tree if item.item_type == "SOCKET" and item.in_out == in_out]


def node_values(node, spec: RendererSpec) -> dict[str, float]:
    """A group node's inputs for `spec`'s parameters as the artist set them (linked ones left out)."""
    inputs = node.inputs
    return {p.name: float(inputs[p.socket].default_value) for p in spec.params if not inputs[p.socket].is_linked}


def material_group_nodes(material, group_name: str) -> list[bpy.types.Node]:
    """The nodes of `material` that use the group `group_name` (or a numbered copy); none when it has no node tree."""
    if material is None or not uses_nodes(material) or material.node_tree is None:
        return []
    return [n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
            and n.node_tree.name.startswith(group_name)]


def scene_group_nodes(scene: bpy.types.Scene, group_name: str) -> list[bpy.types.Node]:
    """Every node using the group `group_name` in the materials of `scene`'s objects."""
    materials = {slot.material for obj in scene.objects for slot in obj.material_slots if slot.material}
    return [node for material in materials for node in material_group_nodes(material, group_name)]


def required_group_nodes(scene: bpy.types.Scene, group_name: str) -> list[bpy.types.Node]:
    """scene_group_nodes, or a one-line VtoError where `scene` has none."""
    nodes = scene_group_nodes(scene, group_name)
    if not nodes:
        raise VtoError(f"scene '{scene.name}' has no material using the '{group_name}' node group")
    return nodes


def scene_group_values(scene: bpy.types.Scene, spec: RendererSpec, group_name: str) -> dict[str, float]:
    """`spec`'s inputs of the first node of `scene` using the group `group_name`, as the artist set them (linked ones
    left out)."""
    return node_values(required_group_nodes(scene, group_name)[0], spec)


def material_name(node: bpy.types.Node) -> str:
    """The name of the material whose node tree holds `node`."""
    return next((m.name for m in bpy.data.materials if m.node_tree == node.id_data), node.id_data.name)


def set_group_values(scene: bpy.types.Scene, spec: RendererSpec, group_name: str, values: dict[str, float],
                     fill_defaults: bool = True) -> dict[str, float]:
    """Set `spec`'s inputs on every node of `scene` using the group `group_name`; returns the values written.

    fill_defaults: a default scene gets every input (unnamed ones at their defaults); a user's scene gets only
    `values`, its other inputs keep the artist's settings. An input driven by a link cannot take a value: that is
    an error naming it, raised before anything is written.
    """
    full = spec.full_values(values)  # checked and clamped
    chosen = full if fill_defaults else {name: full[name] for name in values}
    nodes = required_group_nodes(scene, group_name)
    for node in nodes:
        for name in chosen:
            socket = node.inputs[spec.by_name[name].socket]
            if socket.is_linked:
                raise VtoError(f"input '{socket.name}' of node '{node.name}' in material '{material_name(node)}' is "
                               f"driven by a link, so it cannot take the {name} value; unlink it or leave {name} "
                               "unmodelled")
    for node in nodes:
        for name, value in chosen.items():
            node.inputs[spec.by_name[name].socket].default_value = value
    return chosen


def layer_material(name: str, group: bpy.types.NodeTree, spec: RendererSpec, bare: str, bare_colour: tuple,
                   bare_roughness: float, values: dict[str, float] | None = None) -> bpy.types.Material:
    """A new material: a Principled BSDF `bare` (the surface's own shader, into the group's first input) -> a node of
    `group` named as it (inputs set from `values`, checked against `spec`; the others at the group's defaults) ->
    Material Output."""
    material = bpy.data.materials.new(name)
    enable_nodes(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    bare_node = nodes.new("ShaderNodeBsdfPrincipled")
    bare_node.name = bare_node.label = bare
    bare_node.inputs["Base Color"].default_value = bare_colour
    bare_node.inputs["Roughness"].default_value = bare_roughness
    layer = nodes.new("ShaderNodeGroup")
    layer.name = layer.label = group.name
    layer.node_tree = group
    if values:
        for key, value in spec.check_values(values).items():
            layer.inputs[spec.by_name[key].socket].default_value = value
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(bare_node.outputs[0], layer.inputs[0])
    links.new(layer.outputs[0], output.inputs["Surface"])
    bare_node.location, layer.location, output.location = (-300, 0), (0, 0), (250, 0)
    return material


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


def srgb_colour(b: Builder, gin, names: tuple[str, str, str], label: str):
    """A node of the sRGB helper group reading the group inputs `names` (R, G, B in [0, 255]); its output [0] is the
    linear colour."""
    colour = b.group_node(srgb_group(), label)
    for index, name in enumerate(names):
        b.link(gin[name], colour.inputs[index])
    return colour
