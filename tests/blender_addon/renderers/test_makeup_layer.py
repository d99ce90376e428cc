"""Add Makeup Layer: a face layer's group layered into a character's own skin material, only where the mesh's region
attribute is (Cycles renders of a grid half lips); layers stacked and taken out again; refusals that change nothing;
the operators and the panel's buttons; Match from photo filling the chosen layer of a material wearing two."""

from types import SimpleNamespace

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

import blender_addon  # noqa: E402
from blender_addon.compat import enable_nodes  # noqa: E402
from blender_addon.matching import apply  # noqa: E402
from blender_addon.renderers.cycles import configure_cycles, render_passes, to_display  # noqa: E402
from blender_addon.renderers.makeup_layer import MARK, add_layer, layers, remove_layer  # noqa: E402
from blender_addon.renderers.products import blender_side  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.imageio import write_image  # noqa: E402
from vto_core.inference import EncoderSession  # noqa: E402
from vto_core.photo.photo_reader import load_reference  # noqa: E402
from vto_core.products import EYESHADOW, HAIR, LIPSTICK  # noqa: E402

RES, SAMPLES = 24, 4
SKIN = (0.55, 0.38, 0.3, 1.0)  # linear Base Color of the bare skin
GRID = 9  # vertices a side of the 2 x 2 grid: columns at x = -1, -0.75, ..., 1
LEFT = slice(0, 8)  # pixel columns where vto_lips is 1 on the whole pixel (x < -0.25, before the soft edge)
RIGHT = slice(RES // 2 + 2, RES)  # columns where it is 0, clear of the pixel filter's reach across x = 0
ONE_LEVEL = 1 / 255


@pytest.fixture(scope="module", autouse=True)
def stage():
    """The add-on registered; a scene whose orthographic camera frames a 2 x 2 grid exactly under a sun (no world):
    vto_lips is 1 on its left half and vto_eyelids on its right, on the mesh 'Half Lips'; 'Bare Grid' has none."""
    kinds = ("objects", "meshes", "materials", "scenes", "cameras", "lights", "images")
    before = {kind: set(getattr(bpy.data, kind).keys()) for kind in kinds}
    blender_addon.register()
    bpy.context.preferences.edit.undo_steps = 32
    scene = bpy.data.scenes.new("Makeup Layer Shot")
    grid_mesh("Half Lips", attributes=True), grid_mesh("Bare Grid", attributes=False)
    head = bpy.data.objects.new("Head", bpy.data.meshes["Half Lips"])
    camera = bpy.data.objects.new("Layer Camera", bpy.data.cameras.new("Layer Camera"))
    camera.data.type, camera.data.ortho_scale, camera.location = "ORTHO", 2.0, (0.0, 0.0, 3.0)
    sun = bpy.data.objects.new("Layer Sun", bpy.data.lights.new("Layer Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 3.0, (0.6, 0.3, 0.0)  # tilted: its highlight misses the camera
    for obj in (head, camera, sun):
        scene.collection.objects.link(obj)
    scene.camera, scene.world = camera, None
    yield
    blender_addon.unregister()
    for kind in kinds:
        collection = getattr(bpy.data, kind)
        for name in set(collection.keys()) - before[kind]:
            if name in collection:
                collection.remove(collection[name])


def grid_mesh(name: str, attributes: bool):
    """A 2 x 2 grid in the xy plane, GRID x GRID vertices; with `attributes`, vto_lips 1 at x < 0 (0 from x = 0 on,
    soft over the last quad before it) and vto_eyelids its mirror."""
    mesh = bpy.data.meshes.new(name)
    xs = np.linspace(-1.0, 1.0, GRID)
    vertices = [(x, y, 0.0) for y in xs for x in xs]
    quads = [(j * GRID + i, j * GRID + i + 1, (j + 1) * GRID + i + 1, (j + 1) * GRID + i)
             for j in range(GRID - 1) for i in range(GRID - 1)]
    mesh.from_pydata(vertices, [], quads)
    if attributes:
        for region, inside in ((LIPSTICK.face_region, lambda x: x < 0), (EYESHADOW.face_region, lambda x: x > 0)):
            attribute = mesh.attributes.new(region.attribute, "FLOAT", "POINT")
            attribute.data.foreach_set("value", [float(inside(x)) for x, _, _ in vertices])
    return mesh


def head():
    return bpy.data.objects["Head"]


def wear(mesh_name: str) -> None:
    """The head's mesh: 'Half Lips' (the region attributes) or 'Bare Grid' (none)."""
    head().data = bpy.data.meshes[mesh_name]


def skin_material(name: str = "Skin"):
    """A character's own skin material, the head's only one: Principled BSDF -> Material Output."""
    material = bpy.data.materials.new(name)
    enable_nodes(material)
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = SKIN
    mesh = head().data
    mesh.materials.clear()
    mesh.materials.append(material)
    return material


def render() -> np.ndarray:
    """The shot: (RES, RES, 3) display sRGB, undenoised (the denoiser's reach would cross the region's edge)."""
    scene = bpy.data.scenes["Makeup Layer Shot"]
    configure_cycles(scene, RES, SAMPLES, 0)
    scene.cycles.use_denoising = False
    return to_display(render_passes(scene)["Combined"][..., :3])


def set_inputs(node, spec, values: dict[str, float]) -> None:
    for name, value in values.items():
        node.inputs[spec.by_name[name].socket].default_value = value


RED = {"opacity": 1.0, "red": 230.0, "green": 10.0, "blue": 20.0, "gloss": 0.0, "reflection": 0.0}
BLUE = {"opacity": 1.0, "red": 20.0, "green": 40.0, "blue": 230.0, "height": 1.0, "softness": 0.0}


def links_of(material) -> set[tuple[str, str, str, str]]:
    return {(link.from_node.name, link.from_socket.identifier, link.to_node.name, link.to_socket.identifier)
            for link in material.node_tree.links}


def tree_of(material) -> tuple[set, set]:
    """(node names, links by node name and socket identifier)."""
    return {node.name for node in material.node_tree.nodes}, links_of(material)


def shape_of(material) -> tuple[set, set]:
    """The tree with nodes known by type and layer (names differ between materials built in another order)."""
    def key(node):
        return node.bl_idname, node.get(MARK, "")

    return ({key(node) for node in material.node_tree.nodes},
            {(key(link.from_node), link.from_socket.identifier, key(link.to_node), link.to_socket.identifier)
             for link in material.node_tree.links})


# --- where the layer shows ------------------------------------------------------------------------------------------

def test_the_lipstick_layer_shows_where_the_lips_attribute_is_and_nowhere_else():
    wear("Half Lips")
    material = skin_material()
    bare = render()
    node = add_layer(material, LIPSTICK)
    set_inputs(node, LIPSTICK.spec, RED)
    worn = render()
    assert np.abs(worn[:, RIGHT] - bare[:, RIGHT]).max() <= ONE_LEVEL
    redness = worn[:, LEFT, 0] - worn[:, LEFT, 1:].mean(-1) - (bare[:, LEFT, 0] - bare[:, LEFT, 1:].mean(-1))
    assert redness.mean() > 0.3 and redness.min() > 0.2, redness.mean()  # measured: 0.49 on the whole left


def test_a_mesh_without_the_attribute_renders_as_before():
    wear("Bare Grid")
    material = skin_material()
    bare = render()
    set_inputs(add_layer(material, LIPSTICK), LIPSTICK.spec, RED)
    assert np.abs(render() - bare).max() <= ONE_LEVEL


def test_the_layer_is_framed_marked_and_wired_over_the_skin_shader():
    material = skin_material()
    tree = material.node_tree
    skin, output = tree.nodes["Principled BSDF"], tree.nodes["Material Output"]
    start, skin_at = tuple(output.location), tuple(skin.location)
    node = add_layer(material, LIPSTICK)
    assert node.node_tree.name == "VTO Lipstick" and node.node_tree is blender_side(LIPSTICK).layer_group.group()
    assert node.inputs["Lips"].links[0].from_node == skin
    group_sockets = {item.name: item for item in node.node_tree.interface.items_tree if item.item_type == "SOCKET"}
    assert node.inputs["Opacity"].default_value == group_sockets["Opacity"].default_value  # the group's defaults
    mix = output.inputs["Surface"].links[0].from_node
    assert mix.bl_idname == "ShaderNodeMixShader"
    assert mix.inputs[1].links[0].from_node == skin and mix.inputs[2].links[0].from_node == node
    attribute = mix.inputs[0].links[0].from_node
    assert (attribute.attribute_name, attribute.attribute_type) == ("vto_lips", "GEOMETRY")
    (frame,) = [n for n in tree.nodes if n.bl_idname == "NodeFrame"]
    assert frame.label == "VTO Lipstick Layer" and {node.parent, mix.parent, attribute.parent} == {frame}
    assert {n.get(MARK) for n in (node, mix, attribute, frame)} == {"lipstick"}
    assert output.location.x > start[0] and output.location.y == start[1]  # moved right to make room
    assert tuple(skin.location) == skin_at  # and nothing else moved
    assert all(start[0] <= n.location_absolute.x < output.location.x for n in (node, mix, attribute))


# --- stacking --------------------------------------------------------------------------------------------------------

def test_layers_stack_and_come_out_leaving_the_material_as_it_was():
    wear("Half Lips")
    material = skin_material()
    original, start = tree_of(material), tuple(material.node_tree.nodes["Material Output"].location)
    bare = render()
    set_inputs(add_layer(material, LIPSTICK), LIPSTICK.spec, RED)
    shadow = add_layer(material, EYESHADOW)
    set_inputs(shadow, EYESHADOW.spec, BLUE)
    assert [(product, node.name) for product, node in layers(material)] == [(LIPSTICK, "VTO Lipstick"),
                                                                           (EYESHADOW, "VTO Eye Shadow")]
    both = render()
    assert np.abs(both[:, RIGHT] - bare[:, RIGHT]).mean() > 0.05  # the shadow shows on its half
    remove_layer(material, LIPSTICK)  # the bottom one
    assert [product for product, _ in layers(material)] == [EYESHADOW]
    only_top = render()
    assert np.abs(only_top[:, LEFT] - bare[:, LEFT]).max() <= ONE_LEVEL  # the lipstick is gone
    assert np.abs(only_top[:, RIGHT] - both[:, RIGHT]).max() <= ONE_LEVEL  # the shadow still works
    alone = skin_material("Shadow Alone")
    add_layer(alone, EYESHADOW)
    assert shape_of(material) == shape_of(alone)  # as if only the top had been added
    remove_layer(material, EYESHADOW)
    assert tree_of(material) == original and layers(material) == []
    assert tuple(material.node_tree.nodes["Material Output"].location) == start


def test_removing_the_top_layer_leaves_the_bottom_one_as_if_added_alone():
    material = skin_material()
    original = tree_of(material)
    add_layer(material, LIPSTICK)
    add_layer(material, EYESHADOW)
    remove_layer(material, EYESHADOW)
    alone = skin_material("Lipstick Alone")
    add_layer(alone, LIPSTICK)
    assert shape_of(material) == shape_of(alone) and [p for p, _ in layers(material)] == [LIPSTICK]
    remove_layer(material, LIPSTICK)
    assert tree_of(material) == original


# --- refusals --------------------------------------------------------------------------------------------------------

def no_output(material):
    material.node_tree.nodes.remove(material.node_tree.nodes["Material Output"])


def nothing_into_surface(material):
    tree = material.node_tree
    tree.links.remove(tree.nodes["Material Output"].inputs["Surface"].links[0])


def layered(material):
    add_layer(material, LIPSTICK)


def a_lipstick_material(material):
    """The skin material replaced by an Add VTO Material one: it uses the lipstick group already."""
    vto = blender_side(LIPSTICK).material(f"{material.name} VTO")
    head().data.materials[0] = vto
    return vto


@pytest.mark.parametrize("prepare, product, message", [
    (no_output, LIPSTICK, "has no Material Output"),
    (nothing_into_surface, LIPSTICK, "nothing is linked into its Material Output's Surface"),
    (layered, LIPSTICK, "already wears Lipstick"),
    (a_lipstick_material, LIPSTICK, "already wears Lipstick (its 'VTO Lipstick' node group)"),
    (None, HAIR, "Hair is not a makeup layer of the skin: only Lipstick or Eye Shadow can be layered"),
], ids=["no output", "nothing into surface", "layered already", "a VTO material", "not a face layer"])
def test_a_refused_layer_is_one_line_and_changes_nothing(prepare, product, message):
    material = skin_material()
    material = (prepare(material) or material) if prepare else material
    before, start = tree_of(material), {n.name: tuple(n.location) for n in material.node_tree.nodes}
    with pytest.raises(VtoError) as refused:
        add_layer(material, product)
    assert message in str(refused.value) and len(str(refused.value).splitlines()) == 1, refused.value
    assert tree_of(material) == before and {n.name: tuple(n.location) for n in material.node_tree.nodes} == start


def test_no_material_and_no_layer_to_remove_are_one_line_each():
    for call, message in ((lambda: add_layer(None, LIPSTICK), "no material"),
                          (lambda: remove_layer(None, EYESHADOW), "no material"),
                          (lambda: remove_layer(skin_material(), EYESHADOW), "wears no Eye Shadow layer"),
                          (lambda: remove_layer(skin_material(), HAIR), "Hair is not a makeup layer")):
        with pytest.raises(VtoError, match=message) as refused:
            call()
        assert len(str(refused.value).splitlines()) == 1


def test_a_material_without_a_node_tree_is_one_line():
    plain = bpy.data.materials.new("No Nodes")
    if plain.node_tree is not None:
        pytest.skip("this Blender gives every material a node tree")
    with pytest.raises(VtoError, match="has no node tree") as refused:
        add_layer(plain, LIPSTICK)
    assert len(str(refused.value).splitlines()) == 1 and plain.node_tree is None


# --- the operators and the buttons -----------------------------------------------------------------------------------

class Layout:
    """Records the operator buttons a panel draws: (idname, its product)."""

    def __init__(self, log):
        self.log = log

    def __getattr__(self, name):  # label(), column(), separator(), ...
        return lambda *args, **kwargs: self

    def operator(self, idname, **kwargs):
        button = SimpleNamespace()
        self.log.append((idname, button))
        return button


def buttons(draw) -> list[tuple[str, str]]:
    log = []
    draw(Layout(log))
    return [(idname, getattr(button, "product", "")) for idname, button in log]


def test_the_operators_add_and_remove_a_layer_of_the_active_material_in_one_undo_step():
    material = skin_material()
    name, original = material.name, tree_of(material)
    bpy.context.scene.collection.objects.link(head())  # the operators act on the context's active object
    bpy.context.view_layer.objects.active = head()
    for cls in (bpy.types.VTO_OT_add_makeup_layer, bpy.types.VTO_OT_remove_makeup_layer):
        assert {"REGISTER", "UNDO"} <= set(cls.bl_options)
    from blender_addon.ui.operators import layer_product_items

    assert [item[0] for item in layer_product_items(None, bpy.context)] == ["lipstick", "eyeshadow"]
    assert bpy.ops.vto.add_makeup_layer(product="lipstick") == {"FINISHED"}
    assert bpy.ops.vto.add_makeup_layer(product="eyeshadow") == {"FINISHED"}
    assert [p for p, _ in layers(material)] == [LIPSTICK, EYESHADOW]
    with pytest.raises(RuntimeError, match="already wears Lipstick") as refused:
        bpy.ops.vto.add_makeup_layer(product="lipstick")
    assert len(str(refused.value).strip().splitlines()) == 1
    assert bpy.ops.vto.remove_makeup_layer(product="lipstick") == {"FINISHED"}
    assert bpy.ops.vto.remove_makeup_layer(product="eyeshadow") == {"FINISHED"}
    assert tree_of(material) == original

    bpy.ops.ed.undo_push(message="before the layer")
    assert bpy.ops.vto.add_makeup_layer(product="eyeshadow") == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Add Makeup Layer")  # what Blender's UI does after an operator declaring UNDO
    assert [p for p, _ in layers(bpy.data.materials[name])] == [EYESHADOW]
    bpy.ops.ed.undo()
    assert layers(bpy.data.materials[name]) == []  # undone in one step (data is looked up again after an undo)

    head().data.materials.clear()
    with pytest.raises(RuntimeError, match="has no material") as refused:
        bpy.ops.vto.add_makeup_layer(product="lipstick")
    assert len(str(refused.value).strip().splitlines()) == 1
    bpy.context.scene.collection.objects.unlink(head())


def test_the_panel_offers_each_layer_not_worn_and_takes_out_each_worn():
    from blender_addon.ui.operators import layer_buttons

    material = skin_material()
    panel = bpy.types.VTO_PT_add_lipstick
    assert buttons(lambda layout: panel.draw(SimpleNamespace(layout=layout), SimpleNamespace(material=material))) == [
        ("vto.add_material", "lipstick"), ("vto.add_material", "eyeshadow"),
        ("vto.add_makeup_layer", "lipstick"), ("vto.add_makeup_layer", "eyeshadow")]
    add_layer(material, LIPSTICK)
    assert buttons(lambda layout: layer_buttons(layout, material)) == [
        ("vto.remove_makeup_layer", "lipstick"), ("vto.add_makeup_layer", "eyeshadow")]
    assert buttons(lambda layout: layer_buttons(layout, None)) == []
    vto = blender_side(LIPSTICK).material("A VTO Lipstick Material")  # its group is not a layer: nothing to remove
    assert buttons(lambda layout: layer_buttons(layout, vto)) == [("vto.add_makeup_layer", "eyeshadow")]


# --- Match from photo into a layer ----------------------------------------------------------------------------------

@pytest.fixture
def reference(tmp_path):
    """A small made-up reference (24 x 24, a colour gradient), read whole (Find Region off), as the operator tests'."""
    rows = np.linspace(0.1, 0.9, 24, dtype=np.float32)[:, None]
    cols = np.linspace(0.2, 0.6, 24, dtype=np.float32)[None, :]
    image = np.stack([np.broadcast_to(rows, (24, 24)), np.broadcast_to(cols, (24, 24)),
                      np.full((24, 24), 0.3, np.float32)], -1)
    path = tmp_path / "reference.png"
    write_image(path, image, bits=16)
    return str(path)


def inputs(node, product) -> dict[str, float]:
    return {p.name: float(node.inputs[p.socket].default_value) for p in product.spec.params}


def test_match_fills_the_chosen_products_layer_of_a_material_wearing_two(reference):
    """Fast, the shipped encoders, on each layer in turn: the chosen product's group gets the estimate, the other
    layer's stays as it was."""
    material = skin_material()
    nodes = {product.name: add_layer(material, product) for product in (LIPSTICK, EYESHADOW)}
    for product, other in ((LIPSTICK, EYESHADOW), (EYESHADOW, LIPSTICK)):
        node, other_node = nodes[product.name], nodes[other.name]
        session = EncoderSession(str(apply.default_model(product.name)))
        estimate = session.predict(load_reference(reference))[0]
        expected = {name: float(estimate[name]) for name in session.spec.modelled}
        untouched = inputs(other_node, other)
        assert apply.group_nodes(product, material) == [node]
        assert bpy.ops.vto.match_from_photo(target=product.target, material=material.name, image_path=reference,
                                            quality="FAST", find_region=False) == {"FINISHED"}
        written = inputs(node, product)
        assert {name: written[name] for name in expected} == pytest.approx(expected, abs=1e-4)
        assert inputs(other_node, other) == untouched


def test_match_fills_the_layer_chosen_last_added_first():
    """The panel's Match, Preview and `vto match --material` fill material_product's layer: the newest layer, then
    the one the artist chooses (the Fill row: its group made the active node)."""
    from blender_addon.ui.operators import layer_choice

    material = skin_material()
    add_layer(material, LIPSTICK)
    assert buttons(lambda layout: layer_choice(layout, material)) == []  # one layer: nothing to choose
    add_layer(material, EYESHADOW)
    assert apply.material_product(material) is EYESHADOW
    assert bpy.ops.vto.choose_layer(material_name=material.name, product="lipstick") == {"FINISHED"}
    assert apply.material_product(material) is LIPSTICK
    material.node_tree.nodes.active = material.node_tree.nodes["Material Output"]  # no layer active: the first
    assert apply.material_product(material) is LIPSTICK
    assert buttons(lambda layout: layer_choice(layout, material)) == [
        ("vto.choose_layer", "lipstick"), ("vto.choose_layer", "eyeshadow")]
    remove_layer(material, LIPSTICK)
    with pytest.raises(VtoError, match="wears no Lipstick"):
        apply.choose_layer(material, LIPSTICK)
