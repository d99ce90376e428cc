"""Add Makeup Layer: a face layer's node group layered into a character's own skin material. The layer sits between the
shader that fed the material's output and that output: the product's group over that shader, mixed in by the mesh
attribute of the product's face region (FaceRegion.attribute, which Find Face on Mesh writes: 1 inside, 0 outside), so
it covers that region only and a mesh without the attribute renders as before (an Attribute node reads a missing one
as 0). Layers stack (lipstick and eye shadow on one skin); removing one leaves the material as it was without it."""

from __future__ import annotations

import bpy

from vto_core.errors import VtoError
from vto_core.products import FACE_LAYER, PRODUCTS, Product, either

from ..compat import uses_nodes
from .products import blender_side

MARK = "vto_layer"  # a layer node's custom property: its product's name
LAYER_WIDTH = 480.0  # the room a layer takes left of the output: the output moves right by it (and back on removal)
# By index: Blender 5.0 names the Mix Shader's Fac and the Attribute node's Fac "Factor"
MIX_FAC, MIX_BELOW, MIX_LAYER = 0, 1, 2
ATTRIBUTE_FAC = 2


def is_layer(product: Product) -> bool:
    """Whether `product` can be layered into a skin material (a face layer: lipstick, eye shadow)."""
    return product.kind is FACE_LAYER


def layer_products() -> list[Product]:
    """The declared products that can be layered into a skin material, in declaration order."""
    return [product for product in PRODUCTS.values() if is_layer(product)]


def check_layer(product: Product) -> None:
    """A one-line VtoError where `product` is not a face layer."""
    if not is_layer(product):
        raise VtoError(f"{product.label} is not a makeup layer of the skin: only "
                       f"{either(p.label for p in layer_products())} can be layered into a material")


def node_tree(material) -> bpy.types.NodeTree:
    """`material`'s node tree; a one-line VtoError where there is no material or it has no node tree."""
    if material is None:
        raise VtoError("no material: select an object with its skin material to layer makeup into")
    if not uses_nodes(material) or material.node_tree is None:
        raise VtoError(f"material '{material.name}' has no node tree: turn on Use Nodes first")
    return material.node_tree


def material_output(tree: bpy.types.NodeTree):
    """The tree's active Material Output (the one for every engine first), or None."""
    outputs = [node for node in tree.nodes if node.bl_idname == "ShaderNodeOutputMaterial"]
    active = tree.get_output_node("ALL")
    return active if active in outputs else next((node for node in outputs if node.is_active_output), None)


def fed_output(material, tree: bpy.types.NodeTree):
    """(the active Material Output, the socket feeding its Surface); a one-line VtoError where either is missing."""
    output = material_output(tree)
    if output is None:
        raise VtoError(f"material '{material.name}' has no Material Output to layer makeup in front of")
    surface = output.inputs["Surface"]
    if not surface.is_linked:
        raise VtoError(f"material '{material.name}': nothing is linked into its Material Output's Surface, so there "
                       "is no skin shader to layer makeup over")
    return output, surface.links[0].from_socket


def layer_nodes(tree: bpy.types.NodeTree, product: Product) -> list[bpy.types.Node]:
    """The nodes of `product`'s layer in `tree`: its frame, group node, Attribute and Mix Shader ([] for none)."""
    return [node for node in tree.nodes if node.get(MARK) == product.name]


def new_node(tree: bpy.types.NodeTree, idname: str, product: Product, location: tuple[float, float], frame=None):
    """A node of the product's layer: marked, at `location` (absolute), inside `frame` if given."""
    node = tree.nodes.new(idname)
    node[MARK] = product.name
    node.location = location
    if frame is not None:
        node.parent = frame  # Blender keeps the node where it is, its location now relative to the frame
    return node


def add_layer(material, product: Product) -> bpy.types.Node:
    """Layer `product` into `material` between the shader feeding its active output's Surface and that output: the
    product's group (its inputs at the group's defaults) over that shader, mixed in by the region's attribute.

    Returns the group node, made the tree's active node (the layer Match fills). VtoError (one line, nothing
    changed) where the material has no node tree, no output or nothing feeding its Surface, already wears the
    product, or the product is no face layer.
    """
    check_layer(product)
    tree = node_tree(material)
    output, below = fed_output(material, tree)
    side = blender_side(product)
    if side.nodes(material) or layer_nodes(tree, product):
        raise VtoError(f"material '{material.name}' already wears {product.label} (its '{side.layer_group.name}' "
                       "node group)")
    x, y = output.location
    frame = new_node(tree, "NodeFrame", product, (x, y + 220))
    frame.label = f"VTO {product.label} Layer"
    group = new_node(tree, "ShaderNodeGroup", product, (x + 20, y - 60), frame)
    group.node_tree = side.layer_group.group()
    group.name = group.label = side.layer_group.name
    attribute = new_node(tree, "ShaderNodeAttribute", product, (x + 20, y + 180), frame)
    attribute.attribute_type = "GEOMETRY"
    attribute.attribute_name = product.face_region.attribute
    attribute.label = f"{product.face_region.name.title()} ({attribute.attribute_name})"
    mix = new_node(tree, "ShaderNodeMixShader", product, (x + 260, y), frame)
    mix.label = f"{product.label} on the {product.face_region.name.title()}"
    links = tree.links
    links.new(below, group.inputs[side.layer_group.bare_input])
    links.new(below, mix.inputs[MIX_BELOW])
    links.new(group.outputs[0], mix.inputs[MIX_LAYER])
    links.new(attribute.outputs[ATTRIBUTE_FAC], mix.inputs[MIX_FAC])
    links.new(mix.outputs[0], output.inputs["Surface"])
    output.location.x += LAYER_WIDTH
    tree.nodes.active = group  # the layer Match fills next (matching.apply.material_product)
    return group


def remove_layer(material, product: Product) -> None:
    """Take `product`'s layer out of `material`: the shader below it goes back where its Mix Shader went, its nodes
    are deleted, and the output and the layers above move back into its room. VtoError (one line, nothing changed)
    where the material wears no such layer."""
    check_layer(product)
    tree = node_tree(material)
    nodes = layer_nodes(tree, product)
    if not nodes:
        raise VtoError(f"material '{material.name}' wears no {product.label} layer")
    order = [worn for worn, _ in layers(material)]
    above = order[order.index(product) + 1:] if product in order else []
    moved = [node for upper in above for node in layer_nodes(tree, upper) if node.bl_idname != "NodeFrame"]
    moved += [output for output in [material_output(tree)] if output is not None]
    mix = next((node for node in nodes if node.bl_idname == "ShaderNodeMixShader"), None)
    below = mix.inputs[MIX_BELOW].links[0].from_socket if mix and mix.inputs[MIX_BELOW].is_linked else None
    targets = [link.to_socket for link in mix.outputs[0].links] if mix and below else []
    for node in nodes:
        tree.nodes.remove(node)
    for target in targets:
        tree.links.new(below, target)
    for node in moved:  # a frame's children move, and the frame shrinks around them
        node.location.x -= LAYER_WIDTH


def layers(material) -> list[tuple[Product, bpy.types.Node]]:
    """(product, its group node) of each makeup layer of `material`, bottom (nearest the skin) to top; [] for none."""
    if material is None or not uses_nodes(material) or material.node_tree is None:
        return []
    tree = material.node_tree
    mixes = {node[MARK]: node for node in tree.nodes
             if node.bl_idname == "ShaderNodeMixShader" and node.get(MARK) in PRODUCTS}
    names = {mix.name for mix in mixes.values()}
    depth = {worn: len(upstream(mix) & names) for worn, mix in mixes.items()}  # the layers below it
    groups = {node[MARK]: node for node in tree.nodes if node.bl_idname == "ShaderNodeGroup" and MARK in node}
    return [(PRODUCTS[worn], groups[worn]) for worn in sorted(mixes, key=depth.get) if worn in groups]


def upstream(node: bpy.types.Node) -> set[str]:
    """The names of the nodes that feed `node`, directly or through others."""
    seen, todo = set(), [node]
    while todo:
        for socket in todo.pop().inputs:
            for link in socket.links:
                if link.from_node.name not in seen:
                    seen.add(link.from_node.name)
                    todo.append(link.from_node)
    return seen
