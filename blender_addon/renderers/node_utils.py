"""Small helpers for building node groups: nodes, links, math, and group interfaces from a spec."""

from __future__ import annotations

import bpy

from collections.abc import Iterable

from vto_core.specs import ParamSpec, RendererSpec

from ..compat import compositor_idname

# Bumped whenever a builder changes what it builds, so older groups in saved files are rebuilt.
BUILDER_VERSION = 3
VERSION_KEY = "vto_builder_version"
SOCKET_MAX = 3.0e38  # sockets are float32: the top of an unbounded range


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

    Rebuilding in place keeps every material or compositor that already uses the group.
    """
    group = bpy.data.node_groups.get(name)
    if group is not None and group.bl_idname == tree_type and group.get(VERSION_KEY) == BUILDER_VERSION:
        return group
    if group is None or group.bl_idname != tree_type:
        group = bpy.data.node_groups.new(name, tree_type)
        group.use_fake_user = True  # saved with the .blend even before a material uses it
    group.nodes.clear()
    group.interface.clear()
    build(group)
    group[VERSION_KEY] = BUILDER_VERSION
    return group


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
