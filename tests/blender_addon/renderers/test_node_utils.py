"""node_utils.get_or_create_group: a stale group is rebuilt in place, and the input values artists set on the nodes
using it (in materials, in node groups, in scenes' compositors) are carried across where the input still is."""

import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.compat import COMPOSITOR_TREE, compositor_tree, enable_nodes  # noqa: E402
from blender_addon.renderers.node_utils import SHADER_TREE, VERSION_KEY, get_or_create_group  # noqa: E402
from blender_addon.renderers.products import blender_side  # noqa: E402
from vto_core.products import LIPSTICK  # noqa: E402


def sockets(group, inputs: dict[str, tuple[str, object]]) -> None:
    """Inputs `inputs` (name -> (socket type, default)) and one output on `group`."""
    for name, (kind, default) in inputs.items():
        group.interface.new_socket(name, in_out="INPUT", socket_type=kind).default_value = default
    group.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketFloat")


def built(inputs: dict[str, tuple[str, object]]):
    """A builder (get_or_create_group's) of a group with `inputs` and a Reroute node to tell a rebuild by."""
    def build(group):
        sockets(group, inputs)
        group.nodes.new("NodeReroute").name = f"built with {', '.join(inputs)}"
    return build


def stale(group) -> None:
    """As a group saved by an older builder: no version key."""
    del group[VERSION_KEY]


def links_of(material) -> set[tuple[str, str, str, str]]:
    return {(link.from_node.name, link.from_socket.name, link.to_node.name, link.to_socket.name)
            for link in material.node_tree.links}


def test_a_rebuilt_lipstick_group_keeps_what_the_artist_set_on_a_materials_node():
    side = blender_side(LIPSTICK)
    material = side.material("Kept Lipstick Values")
    (node,) = side.nodes(material)
    node.inputs["Red"].default_value, node.inputs["Opacity"].default_value = 12.0, 0.25
    wired = links_of(material)  # the bare lips into the group, the group into the output
    group = node.node_tree
    group.nodes.new("NodeReroute").name = "left by an older builder"
    stale(group)
    try:
        assert side.layer_group.group() is group and group[VERSION_KEY]
        assert "left by an older builder" not in group.nodes  # rebuilt
        assert node.inputs["Red"].default_value == 12.0 and node.inputs["Opacity"].default_value == 0.25
        assert node.inputs["Green"].default_value == LIPSTICK.spec.by_name["green"].default  # never set: the default
        assert len(wired) >= 2 and links_of(material) == wired  # still wired: the lipstick still shows
    finally:
        bpy.data.materials.remove(material)


def test_values_are_kept_in_materials_node_groups_and_compositors_where_the_name_and_type_still_are():
    first = {"Amount": ("NodeSocketFloat", 0.1), "Tint": ("NodeSocketColor", (1.0, 1.0, 1.0, 1.0)),
             "Gone": ("NodeSocketFloat", 0.0)}
    second = {"Amount": ("NodeSocketFloat", 0.1), "Tint": ("NodeSocketFloat", 0.25),  # Tint is a float now
              "Extra": ("NodeSocketFloat", 0.5)}
    shader = get_or_create_group("Test Kept Shader", SHADER_TREE, built(first))
    material = bpy.data.materials.new("Kept Group Values")
    enable_nodes(material)
    in_material = material.node_tree.nodes.new("ShaderNodeGroup")
    in_material.node_tree = shader
    outer = bpy.data.node_groups.new("Test Outer Group", SHADER_TREE)
    in_group = outer.nodes.new("ShaderNodeGroup")
    in_group.node_tree = shader
    in_material.inputs["Amount"].default_value, in_group.inputs["Amount"].default_value = 0.7, 0.2
    in_material.inputs["Tint"].default_value = (0.1, 0.2, 0.3, 1.0)
    in_material.inputs["Gone"].default_value = 0.9

    compositor = get_or_create_group("Test Kept Compositor", COMPOSITOR_TREE, built(first))
    scene = bpy.data.scenes.new("Kept Compositor Values")
    in_compositor = compositor_tree(scene, create=True).nodes.new("CompositorNodeGroup")
    in_compositor.node_tree = compositor
    in_compositor.inputs["Amount"].default_value = 0.4
    try:
        for group in (shader, compositor):
            stale(group)
        assert get_or_create_group("Test Kept Shader", SHADER_TREE, built(second)) is shader
        assert get_or_create_group("Test Kept Compositor", COMPOSITOR_TREE, built(second)) is compositor
        assert "built with Amount, Tint, Extra" in shader.nodes
        assert in_material.inputs["Amount"].default_value == pytest.approx(0.7)
        assert in_group.inputs["Amount"].default_value == pytest.approx(0.2)
        assert in_compositor.inputs["Amount"].default_value == pytest.approx(0.4)
        assert in_material.inputs["Tint"].default_value == 0.25  # another type: the rebuilt default
        assert in_material.inputs["Extra"].default_value == 0.5  # new: its default, not 0
        assert "Gone" not in in_material.inputs
    finally:
        bpy.data.scenes.remove(scene)
        bpy.data.materials.remove(material)
        for name in ("Test Outer Group", "Test Kept Shader", "Test Kept Compositor"):
            bpy.data.node_groups.remove(bpy.data.node_groups[name])
