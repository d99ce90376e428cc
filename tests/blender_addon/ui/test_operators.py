"""Match from photo in Blender: the starting-point operators, the match operator (values, undo, bad input), the
panels' polls, `vto match --material NAME --save` on a .blend, and eye shadow matched from a photo of one eye."""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.torch, pytest.mark.slow]
bpy = pytest.importorskip("bpy")

import blender_addon  # noqa: E402
from blender_addon.matching import apply  # noqa: E402
from blender_addon.renderers.products import blender_side  # noqa: E402
from vto_core.photo.photo_reader import load_reference  # noqa: E402
from blender_addon.shipped import MODELS  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.imageio import read_image, write_image  # noqa: E402
from vto_core.inference import EncoderSession, cached_session  # noqa: E402
from vto_core.products import (EYESHADOW as EYESHADOW_PRODUCT, HAIR as HAIR_PRODUCT,  # noqa: E402
                               LIPSTICK as LIPSTICK_PRODUCT, PRODUCTS, get_spec)

MODEL = str(apply.default_model("lipstick"))
SPEC = EncoderSession(MODEL).spec  # whatever the shipped model estimates: read from its metadata
LIPSTICK = get_spec("lipstick")
UNTOUCHED = {"sheen": 0.7, "texture": 0.25}  # inputs the shipped model does not estimate: a match leaves them
ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module", autouse=True)
def addon():
    kinds = ("objects", "meshes", "materials", "scenes", "images")
    before = {kind: set(getattr(bpy.data, kind).keys()) for kind in kinds}
    blender_addon.register()
    bpy.context.preferences.edit.undo_steps = 32
    yield
    blender_addon.unregister()
    # Later test modules share this bpy session: remove what these tests made (never reload the file: other modules
    # keep names of data they made, e.g. blender_addon.renderers.lighting's split HDRIs).
    for kind in kinds:
        collection = getattr(bpy.data, kind)
        for name in set(collection.keys()) - before[kind]:
            if name in collection:
                collection.remove(collection[name])
    assert bpy.data.filepath == ""


def tiny_encoder(path: Path, spec, size: int = 8, scale: float = 1.0) -> str:
    """A hand-made VTO encoder: every normalised parameter is `scale` x the image's mean (deterministic, tiny)."""
    import onnx
    from onnx import TensorProto, helper

    m = spec.size
    nodes = [helper.make_node("ReduceMean", ["image", "axes"], ["mean"], keepdims=0),
             helper.make_node("Unsqueeze", ["mean", "one"], ["column"]),
             helper.make_node("Mul", ["column", "weights"], ["params_unit"])]
    inits = [helper.make_tensor("axes", TensorProto.INT64, [3], [1, 2, 3]),
             helper.make_tensor("one", TensorProto.INT64, [1], [1]),
             helper.make_tensor("weights", TensorProto.FLOAT, [1, m], [scale] * m)]
    graph = helper.make_graph(nodes, "tiny", [helper.make_tensor_value_info("image", TensorProto.FLOAT,
                                                                            ["N", 3, size, size])],
                              [helper.make_tensor_value_info("params_unit", TensorProto.FLOAT, ["N", m])], inits)
    model = helper.make_model(graph, ir_version=10, opset_imports=[helper.make_opsetid("", 18)])
    for key, value in {"vto.spec": spec.to_json(), "vto.input_size": f"{size}x{size}", "vto.renderer": spec.renderer,
                       "vto.kind": "encoder"}.items():
        model.metadata_props.add(key=key, value=value)
    onnx.save(model, str(path))
    return str(path)


def gradient_image(height: int = 24, width: int = 24) -> np.ndarray:
    rows = np.linspace(0.1, 0.9, height, dtype=np.float32)[:, None]
    cols = np.linspace(0.2, 0.6, width, dtype=np.float32)[None, :]
    return np.stack([np.broadcast_to(rows, (height, width)), np.broadcast_to(cols, (height, width)),
                     np.full((height, width), 0.3, np.float32)], -1)


@pytest.fixture
def reference(tmp_path):
    path = tmp_path / "reference.png"
    write_image(path, gradient_image(), bits=16)
    return str(path)


def new_mesh(name: str):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    return obj


@pytest.fixture
def material(request):
    """A mesh with a fresh "VTO Lipstick" material made by the operator; two unestimated inputs set by hand."""
    obj = new_mesh(f"Lips {request.node.name}"[:60])
    assert bpy.ops.vto.add_lipstick_material() == {"FINISHED"}
    material = obj.active_material
    for name, value in UNTOUCHED.items():
        group_node(material).inputs[LIPSTICK.by_name[name].socket].default_value = value
    return material.name


def group_node(material):
    if isinstance(material, str):
        material = bpy.data.materials[material]
    (node,) = apply.group_nodes(LIPSTICK_PRODUCT, material)
    return node


def inputs_of(material_name: str) -> dict[str, float]:
    node = group_node(material_name)
    return {p.name: float(node.inputs[p.socket].default_value) for p in LIPSTICK.params}


def expected_estimate(image: np.ndarray, model: str = MODEL) -> dict[str, float]:
    session = EncoderSession(model)
    values = session.predict(image)[0]
    return {name: values[name] for name in session.spec.modelled}


def fast_estimate(image: np.ndarray, lips: np.ndarray, box: tuple[int, int, int, int], model: str = MODEL
                  ) -> dict[str, float]:
    """Fast on a reference (H, W, 3) whose lips (H, W) are known: the encoder's estimate of the part `box` (x, y, w,
    h) of the photo with its light, read from the skin beside the lips, taken out."""
    from vto_core.photo.photo_light import light_of, neutral_photo

    x, y, w, h = box
    return expected_estimate(np.ascontiguousarray(neutral_photo(image, light_of(image, lips))[y:y + h, x:x + w]),
                             model)


def run_operator(operator, **kwargs):
    """(the operator's result, None) or ({'CANCELLED'}, the one error line it reported)."""
    try:
        return operator(**kwargs), None
    except RuntimeError as exc:
        return {"CANCELLED"}, str(exc).strip()


def run_match(**kwargs):
    """The operator as a script calls it: ({'FINISHED'}, None) or ({'CANCELLED'}, the one error line).

    These tests check Match's mechanics on small made-up references that are not lips, so lipstick takes them as
    they are (find_lips off) unless a test asks otherwise; test_a_portrait_is_matched_at_its_lips finds lips."""
    if kwargs.get("target", "MATERIAL") == "MATERIAL":
        kwargs.setdefault("find_lips", False)
    try:
        return bpy.ops.vto.match_from_photo(**kwargs), None
    except RuntimeError as exc:
        return {"CANCELLED"}, str(exc).strip()


def test_add_lipstick_material_wires_the_group_between_a_bare_shader_and_the_output(material):
    tree = bpy.data.materials[material].node_tree
    node = group_node(material)
    assert node.node_tree.name == "VTO Lipstick"
    (output,) = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    assert output.inputs["Surface"].links[0].from_node == node
    assert node.inputs["Lips"].links[0].from_node.bl_idname == "ShaderNodeBsdfPrincipled"
    assert [p.socket for p in LIPSTICK.params] == [s.name for s in node.inputs][1:]
    obj = bpy.context.view_layer.objects.active
    assert obj.active_material.name == material and obj.data.materials[-1].name == material
    assert {"REGISTER", "UNDO"} <= set(bpy.types.VTO_OT_add_lipstick_material.bl_options)


def test_add_lipstick_material_needs_a_mesh():
    empty = bpy.data.objects.new("Empty For VTO", None)
    bpy.context.scene.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    count = len(bpy.data.materials)
    with pytest.raises(RuntimeError, match="poll"):
        bpy.ops.vto.add_lipstick_material()
    with pytest.raises(VtoError, match="select a mesh"):
        blender_side("lipstick").add_group(empty)
    assert len(bpy.data.materials) == count


def test_add_hair_compositor_wires_both_groups_to_the_outputs():
    scene = bpy.data.scenes.new("Hair Shot")
    with bpy.context.temp_override(scene=scene):
        assert bpy.ops.vto.add_hair_compositor() == {"FINISHED"}
    nodes = {n.node_tree.name: n for n in apply.group_nodes(HAIR_PRODUCT, scene)}
    assert set(nodes) == {"VTO Hair Swatch", "VTO Hair Color"}
    color, swatch = nodes["VTO Hair Color"], nodes["VTO Hair Swatch"]
    assert color.outputs[0].links[0].to_node.bl_idname in ("CompositorNodeComposite", "NodeGroupOutput")
    assert color.inputs["Image"].links[0].from_node.bl_idname == "CompositorNodeRLayers"
    assert swatch.outputs[0].links[0].to_node.bl_idname == "CompositorNodeViewer"
    assert swatch.inputs["Image"].links[0].from_node.image.name == "hair_swatch.png"
    assert color.inputs["Mask"].default_value == 1.0 and color.inputs["Gradient"].default_value == 1.0
    hair = get_spec("hair")
    assert {p.socket for p in hair.params} <= {s.name for n in nodes.values() for s in n.inputs}


def test_match_writes_exactly_the_encoders_estimate_and_nothing_else(material, reference):
    before = inputs_of(material)
    assert run_match(material=material, image_path=reference) == ({"FINISHED"}, None)
    after = inputs_of(material)
    expected = expected_estimate(load_reference(reference))
    for name, value in expected.items():
        assert after[name] == pytest.approx(value, abs=1e-4)
        param = LIPSTICK.by_name[name]
        assert param.low <= after[name] <= param.high
    changed = {k for k in after if after[k] != before[k]}
    assert changed <= set(SPEC.modelled) and changed
    assert {k: after[k] for k in UNTOUCHED} == pytest.approx(UNTOUCHED)
    last = json.loads(bpy.data.materials[material].vto_match.last_estimate)
    assert last["renderer"] == "lipstick" and last["values"] == pytest.approx(expected)


def test_one_undo_step_restores_the_previous_values(material, reference):
    before = inputs_of(material)
    bpy.ops.ed.undo_push(message="before match")
    assert run_match(material=material, image_path=reference)[0] == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Match")  # what Blender's UI does after an operator declaring UNDO
    assert inputs_of(material) != before
    bpy.ops.ed.undo()
    assert inputs_of(material) == before
    assert {"REGISTER", "UNDO"} <= set(bpy.types.VTO_OT_match_from_photo.bl_options)


def test_a_large_reference_is_block_reduced_first_with_the_same_result():
    from vto_core.imageio import resize
    from vto_core.inference import shrink

    rows = np.linspace(0, 1, 1024, dtype=np.float32)
    image = np.stack([np.add.outer(rows, rows) / 2, np.outer(rows, rows), np.full((1024, 1024), 0.4, np.float32)], -1)
    reduced = shrink(image, 64, 64)
    assert reduced.shape == (128, 128, 3) and shrink(image[:1000, :300], 64, 64).shape == (500, 150, 3)
    small = image[:16]
    assert shrink(small, 64, 64) is small  # nothing to reduce
    direct, fast = resize(image, 64, 64), resize(reduced, 64, 64)
    assert np.abs(direct - fast).max() < 2e-3


def test_the_model_is_the_override_else_the_preference_else_the_shipped_one(tmp_path):
    from blender_addon.ui.preferences import preference_model

    assert apply.resolve_model("hair") == ROOT / "blender_addon" / "models" / "hair_encoder.onnx"
    assert apply.resolve_model("lipstick", "", str(tmp_path / "pref.onnx")) == tmp_path / "pref.onnx"
    assert apply.resolve_model("lipstick", str(tmp_path / "own.onnx"), str(tmp_path / "pref.onnx")) == (
        tmp_path / "own.onnx")
    assert preference_model(bpy.context, "lipstick") == ""  # registered without addon_utils: no preferences


def test_the_session_is_made_once_per_model_file(tmp_path):
    copy = tmp_path / "model.onnx"
    copy.write_bytes(Path(MODEL).read_bytes())
    first = cached_session(copy)
    assert cached_session(str(copy)) is first
    os.utime(copy, ns=(0, 10**9))  # a model written over the old one is loaded again
    assert cached_session(copy) is not first


@pytest.fixture
def odd_files(tmp_path):
    """Inputs that are bad, or unusual but good, written once per test."""
    import onnx
    from onnx import TensorProto, helper

    image = gradient_image()
    (tmp_path / "empty.png").write_bytes(b"")
    (tmp_path / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4)
    (tmp_path / "notes.png").write_text("not an image")
    write_image(tmp_path / "one.png", np.full((1, 1, 3), 0.5, np.float32))
    write_image(tmp_path / "grey.png", image[..., 0])
    write_image(tmp_path / "deep.png", image, bits=16)
    write_image(tmp_path / "rgba.png", image, alpha=np.full(image.shape[:2], 0.5, np.float32))
    nan = image.copy()
    nan[2:5, 3:9] = np.nan
    write_image(tmp_path / "nan.exr", nan, bits="float")
    write_image(tmp_path / "all_nan.exr", np.full((16, 16, 3), np.nan, np.float32), bits="float")
    wide = np.tile(image[:16], (1, 4096 // image.shape[1] + 1, 1))[:, :4096]  # colour in it: not a toned print
    write_image(tmp_path / "wide.png", wide * np.linspace(0.2, 1, 4096)[None, :, None])
    (tmp_path / "junk.onnx").write_bytes(b"not a model")
    (tmp_path / "truncated.onnx").write_bytes(Path(MODEL).read_bytes()[:100_000])
    value = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])
    graph = helper.make_graph([helper.make_node("Identity", ["x"], ["y"])], "foreign", [value],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])])
    onnx.save(helper.make_model(graph, ir_version=10, opset_imports=[helper.make_opsetid("", 18)]),
              str(tmp_path / "foreign.onnx"))
    tiny_encoder(tmp_path / "hair.onnx", get_spec("hair"))
    other = json.loads(LIPSTICK.to_json())
    other["params"][1]["high"] = 1.0  # red in [0, 1]: another version of the spec
    from vto_core.specs import RendererSpec

    tiny_encoder(tmp_path / "other_spec.onnx", RendererSpec.from_dict(other).select(["opacity", "red"]))
    return tmp_path


BAD = [
    ({"image_path": "{tmp}/none.png"}, "no image at"),
    ({"image_path": "{tmp}/empty.png"}, "cannot read image"),
    ({"image_path": "{tmp}/corrupt.png"}, "cannot read image"),
    ({"image_path": "{tmp}/notes.png"}, "cannot read image"),
    ({"image_path": "{tmp}/one.png"}, "image is 1x1; at least 8x8"),
    ({"image_path": "{tmp}/all_nan.exr"}, "every pixel is NaN or infinite"),
    ({"image_path": "{tmp}/grey.png"}, "a black-and-white photo has no lipstick colour to read"),
    ({"image_name": "no such image"}, "no image 'no such image' in this .blend"),
    ({"model_path": "{tmp}/none.onnx"}, "no encoder model"),
    ({"model_path": "{tmp}/junk.onnx"}, "cannot load"),
    ({"model_path": "{tmp}/truncated.onnx"}, "cannot load"),
    ({"model_path": "{tmp}/foreign.onnx"}, "not a VTO encoder"),
    ({"model_path": "{tmp}/hair.onnx"}, "estimates hair parameters, not lipstick"),
    ({"model_path": "{tmp}/other_spec.onnx"}, "made for another lipstick spec: its 'red' spans [0, 1]"),
    ({"quality": "BETTER"}, "needs to know where they are"),
    ({"crop": (20, 20, 10, 10)}, "does not fit the 24x24 image"),
    ({"mask_path": "{tmp}/none.png"}, "no mask image at"),
    ({"material": "No Such Material"}, "no material 'No Such Material'"),
]


@pytest.mark.parametrize("kwargs, message", BAD, ids=[m.split(" ")[0] + str(i) for i, (_, m) in enumerate(BAD)])
def test_bad_input_reports_one_line_and_changes_nothing(kwargs, message, material, reference, odd_files):
    arguments = {"material": material, "image_path": reference}
    arguments.update({k: v.replace("{tmp}", str(odd_files)) if isinstance(v, str) else v for k, v in kwargs.items()})
    if "image_name" in kwargs:
        del arguments["image_path"]
    before = inputs_of(material)
    files = {p.name: p.read_bytes() for p in odd_files.iterdir()}
    result, error = run_match(**arguments)
    assert result == {"CANCELLED"}
    assert len(error.splitlines()) == 1 and error.startswith("Error: ") and message in error, error
    assert inputs_of(material) == before and bpy.data.materials[material].vto_match.last_estimate == ""
    assert {p.name: p.read_bytes() for p in odd_files.iterdir()} == files


def test_a_material_without_the_group_or_with_a_linked_input_changes_nothing(reference):
    from blender_addon.compat import enable_nodes

    plain = bpy.data.materials.new("Plain VTO Test")
    enable_nodes(plain)
    result, error = run_match(material=plain.name, image_path=reference)
    assert result == {"CANCELLED"} and "does not use the 'VTO Lipstick' node group" in error
    obj = new_mesh("Linked Lips")
    bpy.ops.vto.add_lipstick_material()
    name = obj.active_material.name
    tree = obj.active_material.node_tree
    value = tree.nodes.new("ShaderNodeValue")
    red = LIPSTICK.by_name["red"].socket
    tree.links.new(value.outputs[0], group_node(name).inputs[red])
    before = inputs_of(name)
    result, error = run_match(material=name, image_path=reference)
    assert result == {"CANCELLED"} and f"input '{red}' of node 'VTO Lipstick'" in error and "driven by a link" in error
    assert inputs_of(name) == before


@pytest.mark.parametrize("name", ["deep.png", "rgba.png", "nan.exr", "wide.png"])
def test_unusual_but_valid_images_are_matched(name, material, odd_files):
    path = str(odd_files / name)
    assert run_match(material=material, image_path=path) == ({"FINISHED"}, None)
    if name == "nan.exr":
        with pytest.warns(UserWarning, match="18 NaN or infinite pixel"):
            reference = load_reference(path)
    else:
        reference = load_reference(path)
    expected = expected_estimate(reference)
    after = inputs_of(material)
    assert {n: after[n] for n in expected} == pytest.approx(expected, abs=1e-4)
    assert all(np.isfinite(v) for v in after.values())


def test_nan_pixels_are_read_as_zero_with_a_warning(odd_files):
    job = apply.MatchJob("lipstick", {"image_path": str(odd_files / "nan.exr"), "find_region": False},
                         material_name=new_material())
    assert job.warnings == [f"{odd_files / 'nan.exr'}: 18 NaN or infinite pixel(s) read as 0 (NaN, -inf) or 1 (+inf)"]
    image = job.prepared["reference"].image
    assert np.isfinite(image).all() and (image[2:5, 3:9] == 0).all()


def new_material() -> str:
    obj = new_mesh("NaN Lips")
    return blender_side("lipstick").add_group(obj).name


def test_crop_in_pixels_or_fractions_and_an_image_datablock(material, reference):
    image = load_reference(reference)
    expected = expected_estimate(np.ascontiguousarray(image[6:18, 0:12]))
    for crop in ((0, 6, 12, 12), (0.0, 0.25, 0.5, 0.5)):
        assert run_match(material=material, image_path=reference, crop=crop)[0] == {"FINISHED"}
        after = inputs_of(material)
        assert {n: after[n] for n in expected} == pytest.approx(expected, abs=1e-4)
    mask = np.zeros((24, 24), np.float32)
    mask[6:18, 0:12] = 1.0  # a lipstick mask: the reference is framed around the lips' box
    write_image(Path(reference).with_name("lips_mask.png"), mask)
    assert run_match(material=material, image_path=reference,
                     mask_path=str(Path(reference).with_name("lips_mask.png")))[0] == {"FINISHED"}
    after = inputs_of(material)
    framed = fast_estimate(image, mask, (0, 4, 16, 16))  # 12 px of lips = 0.78 of a 16 px square
    assert {n: after[n] for n in framed} == pytest.approx(framed, abs=1e-4) != expected
    # an image already in the .blend (no file behind it): byte pixels are display values
    pixels = gradient_image(16, 16)
    datablock = bpy.data.images.new("VTO Test Reference", 16, 16)
    rgba = np.concatenate([np.flipud(pixels), np.ones((16, 16, 1), np.float32)], -1)
    datablock.pixels.foreach_set(rgba.reshape(-1))
    assert run_match(material=material, image_name=datablock.name)[0] == {"FINISHED"}
    stored = np.empty(16 * 16 * 4, np.float32)
    datablock.pixels.foreach_get(stored)  # 8-bit codes / 255, bottom row first
    stored = np.flipud(stored.reshape(16, 16, 4))[..., :3]
    assert np.abs(stored - pixels).max() <= 1 / 255 + 1e-6
    expected = expected_estimate(np.ascontiguousarray(stored))
    after = inputs_of(material)
    assert {n: after[n] for n in expected} == pytest.approx(expected, abs=1e-4)


def test_the_panels_poll_by_material_and_editor(material):
    plain = bpy.data.materials.new("Plain Poll Test")
    match_panel, add_panel = bpy.types.VTO_PT_match_material, bpy.types.VTO_PT_add_lipstick
    obj = bpy.context.view_layer.objects.active
    assert match_panel.poll(SimpleNamespace(material=bpy.data.materials[material])) is True
    assert match_panel.poll(SimpleNamespace(material=plain)) is False
    assert match_panel.poll(SimpleNamespace(material=None)) is False
    assert add_panel.poll(SimpleNamespace(object=obj, material=plain)) is True
    assert add_panel.poll(SimpleNamespace(object=obj, material=bpy.data.materials[material])) is False
    hair_panel = bpy.types.VTO_PT_match_hair
    scene = bpy.context.scene
    assert hair_panel.poll(SimpleNamespace(space_data=SimpleNamespace(tree_type="CompositorNodeTree"), scene=scene))
    assert not hair_panel.poll(SimpleNamespace(space_data=SimpleNamespace(tree_type="ShaderNodeTree"), scene=scene))
    assert (hair_panel.bl_space_type, hair_panel.bl_region_type) == ("NODE_EDITOR", "UI")
    assert (match_panel.bl_space_type, match_panel.bl_context) == ("PROPERTIES", "material")


def test_hair_fast_and_better_write_the_compositor_groups(tmp_path):
    hair = get_spec("hair")
    model = tiny_encoder(tmp_path / "hair.onnx", hair, scale=0.8)
    scene = bpy.data.scenes.new("Hair Match")
    with bpy.context.temp_override(scene=scene):
        bpy.ops.vto.add_hair_compositor()
    photo = gradient_image(16, 16)
    write_image(tmp_path / "photo.png", photo, bits=16)
    mask = np.zeros((16, 16), np.float32)
    mask[:10] = 1.0
    write_image(tmp_path / "photo_mask.png", mask)

    def values():
        return {p.name: float(n.inputs[p.socket].default_value) for n in apply.group_nodes(HAIR_PRODUCT, scene) for p in hair.params
                if p.socket in n.inputs}

    with bpy.context.temp_override(scene=scene):
        assert run_match(target="HAIR", image_path=str(tmp_path / "photo.png"), model_path=model) == ({"FINISHED"},
                                                                                                      None)
        fast = values()
        estimate = expected_estimate(load_reference(str(tmp_path / "photo.png")), model)
        assert fast == pytest.approx({**estimate, "intensity": 1.0, "blend": -1.0}, abs=1e-4)  # a photo: full effect
        assert run_match(target="HAIR", image_path=str(tmp_path / "photo.png"), model_path=model, quality="BETTER",
                         mask_path=str(tmp_path / "photo_mask.png"))[0] == {"FINISHED"}
    better = values()
    assert better != fast and hair.check_values(better) == pytest.approx(better)
    assert (better["intensity"], better["blend"]) == (1.0, -1.0)


def test_hair_fast_polishes_as_vto_match_does_and_leaves_nothing_behind(tmp_path):
    """The panel's hair Fast with the shipped models: the polish's stage passes run as steps of the operator (a budget
    of fast_polish renders), the values are those `vto match` writes (colour_fit.fit_photo_fast), and the default
    scenes the passes render are gone afterwards."""
    from blender_addon.matching.colour_fit import fit_photo_fast
    from blender_addon.matching.reference import read_reference

    model = str(MODELS / "hair_encoder.onnx")
    scene = bpy.data.scenes.new("Hair Polish")
    with bpy.context.temp_override(scene=scene):
        bpy.ops.vto.add_hair_compositor()
    rng = np.random.default_rng(3)
    photo = np.clip(np.array([0.35, 0.22, 0.12]) * (1 + 0.2 * rng.standard_normal((24, 24, 1))), 0, 1)
    write_image(tmp_path / "auburn.png", photo.astype(np.float32), bits=16)
    write_image(tmp_path / "auburn_mask.png", np.ones((24, 24), np.float32))
    settings = {"image_path": str(tmp_path / "auburn.png"), "mask_path": str(tmp_path / "auburn_mask.png")}
    assert apply.prepare("hair", {**settings, "model_path": model, "quality": "FAST"})["budget"] == HAIR_PRODUCT.fit.fast_polish
    kinds = ("scenes", "node_groups", "images", "objects", "materials")
    before = {kind: set(getattr(bpy.data, kind).keys()) for kind in kinds}
    with bpy.context.temp_override(scene=scene):
        assert run_match(target="HAIR", model_path=model, **settings)[0] == {"FINISHED"}
    assert {kind: set(getattr(bpy.data, kind).keys()) for kind in kinds} == before
    written = {p.name: float(n.inputs[p.socket].default_value) for n in apply.group_nodes(HAIR_PRODUCT, scene)
               for p in get_spec("hair").params if p.socket in n.inputs}
    session = EncoderSession(model)
    reference = read_reference("hair", settings)  # as the panel reads it
    estimate = session.predict(reference.image)[0]
    expected = fit_photo_fast(session.spec, reference.region, {k: estimate[k] for k in session.spec.modelled})[0]
    assert {k: written[k] for k in expected} == pytest.approx(expected, abs=1e-4)


@pytest.fixture(scope="module")
def portrait(tmp_path_factory):
    """scikit-image's astronaut portrait (public domain, NASA), whole."""
    import skimage.data

    path = tmp_path_factory.mktemp("portrait") / "astronaut.png"
    write_image(path, skimage.data.astronaut().astype(np.float32) / 255)
    return str(path)


def test_a_portrait_is_matched_at_its_lips_and_better_leaves_nothing_behind(material, portrait):
    from blender_addon.ui import thumbnail
    from blender_addon.matching.reference import read_reference

    framed = read_reference("lipstick", {"image_path": portrait})
    assert run_match(material=material, image_path=portrait, find_lips=True) == ({"FINISHED"}, None)
    fast = inputs_of(material)
    expected = fast_estimate(framed.whole, framed.found.mask, framed.box)
    assert {n: fast[n] for n in SPEC.modelled} == pytest.approx(expected, abs=1e-4)
    assert framed.light.read_from == "skin" and not np.allclose(framed.light.gains, 1.0, atol=0.01)
    assert expected != pytest.approx(expected_estimate(framed.whole[framed.box[1]:framed.box[1] + framed.box[3],
                                                                    framed.box[0]:framed.box[0] + framed.box[2]]),
                                     abs=0.5)  # her light, taken out, moved the estimate
    reference = read_reference("lipstick", {"image_path": portrait})
    # what the panel's thumbnail shows
    canvas = thumbnail.compose(reference.whole, None, None, reference.found, product=LIPSTICK_PRODUCT)
    rows, cols = np.nonzero(np.all(np.isclose(canvas[..., :3], thumbnail.LIPS_COLOUR), axis=-1))
    x, y, w, h = (v * thumbnail.SIZE / 512 for v in reference.found.box)
    assert len(rows) > 20 and x - 2 <= cols.mean() - w / 2 <= x + 2 and y - 3 <= rows.mean() - h / 2 <= y + 3
    before = {kind: set(getattr(bpy.data, kind).keys()) for kind in ("scenes", "objects", "images", "node_groups")}
    assert run_match(material=material, image_path=portrait, find_lips=True, quality="BETTER") == ({"FINISHED"},
                                                                                                  None)
    better = inputs_of(material)
    assert better != fast and LIPSTICK.check_values(better) == pytest.approx(better)
    assert {kind: set(getattr(bpy.data, kind).keys()) for kind in before} == before  # the fit's scenes are gone


def test_match_makes_the_preview_on_photo_and_a_photo_without_a_face_says_so(material, portrait, odd_files):
    from blender_addon.ui import preview

    target = bpy.data.materials[material]
    assert run_match(material=material, image_path=portrait, find_lips=True) == ({"FINISHED"}, None)
    assert preview.shown(target)[1] == ""  # made after Match, from the values Match wrote
    values = preview.material_values(target)[1]
    assert values["red"] == pytest.approx(inputs_of(material)["red"], abs=1e-3)
    picture = preview.picture(target)
    left, right = picture[:, :preview.SIZE], picture[:, preview.SIZE:]
    assert picture.shape == (preview.SIZE, 2 * preview.SIZE, 3) and np.abs(left - right).max() > 0.05
    assert np.abs(left - right).mean() < 0.05  # the photo beside itself, only its lips changed
    before = inputs_of(material)
    target.vto_match.image_path = str(odd_files / "deep.png")  # a gradient: no face to try it on
    result, error = run_operator(bpy.ops.vto.preview_on_photo, material=material)
    assert result == {"CANCELLED"} and error.startswith("Error: no face found")
    note = preview.shown(target)[1]
    assert note.startswith("no face found") and "\n" not in note and preview.picture(target) is None
    assert inputs_of(material) == before  # the preview changes nothing


def test_the_thumbnail_outlines_the_lips_found():
    from blender_addon.ui.thumbnail import LIPS_COLOUR, compose
    from vto_core.photo.lips_locator import close_up

    picture = np.full((64, 64, 3), 0.5, np.float32)
    lips = close_up((64, 64), (0.78, 0.4, 0.5, 0.5), 1.0, "")
    canvas = compose(picture, None, None, lips, product=LIPSTICK_PRODUCT)
    cyan = np.all(np.isclose(canvas[..., :3], LIPS_COLOUR), axis=-1)
    rows, cols = np.nonzero(cyan)
    assert cyan.sum() > 100 and abs(cols.mean() - 64) < 6 and abs(rows.mean() - 64) < 6  # the lens, centred


def test_the_thumbnail_draws_a_tilted_faces_frame_turned_on_the_photo_as_shown(portrait):
    from benchmarks.common import tilted as turned
    from blender_addon.shipped import photo_reader
    from vto_core.photo.framing import turned_square
    from vto_core.products import LIPS
    from blender_addon.ui.thumbnail import CROP_COLOUR, SIZE, compose

    photo = read_image(portrait)[0]
    tilted = turned(photo, 30)
    reference = photo_reader().region_reference(LIPSTICK_PRODUCT, tilted)
    canvas = compose(tilted, None, None, reference.found, product=LIPSTICK_PRODUCT)
    frame = np.all(np.isclose(canvas[..., :3], CROP_COLOUR), axis=-1)
    centre, side = turned_square(reference.found.outer, reference.turn, LIPS.frame_share)
    across = np.array([np.cos(reference.turn), np.sin(reference.turn)])
    down = np.array([-across[1], across[0]])
    scale = SIZE / max(tilted.shape[:2])
    offset = (SIZE - np.array(tilted.shape[1::-1]) * scale) // 2
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):  # each corner of the turned square is drawn
        x, y = (centre + (across * sx + down * sy) * side / 2) * scale + offset
        assert frame[int(y) - 2:int(y) + 3, int(x) - 2:int(x) + 3].any(), (sx, sy)
    rows = np.nonzero(frame.any(axis=1))[0]
    assert max(frame[row].sum() for row in rows) < 0.8 * side * scale  # no row holds a level edge: it is turned


def test_the_thumbnail_outlines_the_hair_found():
    from blender_addon.ui.thumbnail import HAIR_COLOUR, compose
    from vto_core.photo.hair_locator import HairFound

    picture = np.full((64, 64, 3), 0.5, np.float32)
    mask = np.zeros((64, 64), np.float32)
    mask[8:24, 16:48] = 1.0  # a band of hair across the top
    canvas = compose(picture, None, None, hair=HairFound(mask, (16, 8, 32, 16), 1, ""))
    green = np.all(np.isclose(canvas[..., :3], HAIR_COLOUR), axis=-1)
    rows, cols = np.nonzero(green)
    assert green.sum() > 50 and abs(rows.mean() - 32) < 3 and abs(cols.mean() - 64) < 3  # its outline, scaled 2x
    assert not green[20:44, 40:88].any()  # an outline, not a fill


def test_hair_is_found_in_a_portrait_by_the_operator_and_no_hair_changes_nothing(portrait, tmp_path):
    from blender_addon.matching.batch import fast_values
    from blender_addon.matching.reference import read_reference

    hair = get_spec("hair")
    scene = bpy.data.scenes.new("Hair Portrait")
    with bpy.context.temp_override(scene=scene):
        bpy.ops.vto.add_hair_compositor()

    def values():
        return {p.name: float(n.inputs[p.socket].default_value) for n in apply.group_nodes(HAIR_PRODUCT, scene) for p in hair.params
                if p.socket in n.inputs}

    before = values()
    noise = tmp_path / "noise.png"
    write_image(noise, np.random.default_rng(0).random((200, 200, 3)).astype(np.float32))
    with bpy.context.temp_override(scene=scene):
        status, error = run_match(target="HAIR", image_path=str(noise))
        assert status == {"CANCELLED"} and values() == before
        assert error == "Error: no hair found: no face, and the image is noise, not a patch of hair"
        assert run_match(target="HAIR", image_path=portrait) == ({"FINISHED"}, None)
    found = read_reference("hair", {"image_path": portrait})
    assert found.hair is not None
    session = EncoderSession(str(MODELS / "hair_encoder.onnx"))
    estimate = fast_values(session.spec, found, session.predict(found.image)[0])  # what batch and the operator write
    written = values()
    assert {k: written[k] for k in hair.modelled} == pytest.approx({k: estimate[k] for k in hair.modelled}, abs=1e-4)


# --- `vto match --material NAME --save` -------------------------------------------------------------------------

def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def blend(tmp_path, material):
    """A .blend holding the lipstick material (saved as a copy: the session's own file stays unnamed)."""
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return path


def vto(*argv):
    return subprocess.run([sys.executable, "-m", "vto_core.cli", "match", *argv], capture_output=True, text=True,
                          cwd=ROOT)


def test_cli_material_save_writes_the_estimate_into_the_blend(blend, material, reference):
    before = digest(blend)
    out = blend.parent / "params.json"
    done = vto("--material", material, "--image", reference, "--whole-image", "--blend", str(blend), "--save",
               "--out-params", str(out))
    assert done.returncode == 0, done.stderr[-800:]
    printed = json.loads(done.stdout.strip().splitlines()[-1])
    expected = expected_estimate(load_reference(reference))
    assert printed["params"] == pytest.approx(expected, abs=1e-6)
    assert json.loads(out.read_text()) == {"renderer": "lipstick", "params": printed["params"]}
    assert digest(blend) != before
    assert sorted(os.listdir(blend.parent)) == ["params.json", "reference.png", "scene.blend"]  # no temporary left
    stored = saved_values(blend, material)
    assert {n: stored[n] for n in expected} == pytest.approx(expected, abs=1e-4)
    assert {k: stored[k] for k in UNTOUCHED} == pytest.approx(UNTOUCHED)


def saved_values(blend: Path, material: str) -> dict[str, float]:
    """The lipstick group inputs of `material` as saved in `blend` (read by another process, so this session's file
    stays unnamed)."""
    child = ("import bpy, sys, json; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
             "n = [n for n in bpy.data.materials[sys.argv[2]].node_tree.nodes if n.bl_idname == 'ShaderNodeGroup'][0]; "
             "print(json.dumps({s.name: s.default_value for s in n.inputs[1:]}))")
    read = subprocess.run([sys.executable, "-c", child, str(blend), material], capture_output=True, text=True)
    stored = json.loads(read.stdout.strip().splitlines()[-1])
    return {p.name: stored[p.socket] for p in LIPSTICK.params}


def test_cli_inside_blender_uses_the_open_file(blend, material, reference):
    """`blender -b scene.blend -c vto match --material NAME --image IMG --save`: the file is open, no --blend."""
    child = ("import bpy, sys; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); import blender_addon; "
             "blender_addon.register(); sys.exit(blender_addon.run_cli(sys.argv[2:]))")
    done = subprocess.run([sys.executable, "-c", child, str(blend), "match", "--material", material, "--image",
                           reference, "--whole-image", "--save"], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-800:]
    expected = expected_estimate(load_reference(reference))
    stored = saved_values(blend, material)
    assert {n: stored[n] for n in expected} == pytest.approx(expected, abs=1e-4)


@pytest.mark.parametrize("argv, message", [
    (["--image", "{tmp}/none.png"], "no image at"),
    (["--image", "{tmp}/empty.png"], "cannot read image"),
    (["--image", "{tmp}/one.png"], "at least 8x8"),
    (["--model", "{tmp}/truncated.onnx"], "cannot load"),
    (["--model", "{tmp}/hair.onnx"], "not lipstick"),
    (["--material", "Nope"], "no material 'Nope'"),
    (["--material", "Plain"], "does not use the 'VTO Lipstick' node group"),
    (["--crop", "1,2,3"], "--crop takes x,y,w,h"),
    (["--refine", "render:5"], "--material takes --quality"),
    (["--save", None], "add --save"),
])
def test_cli_bad_input_is_one_line_and_leaves_the_blend_byte_identical(argv, message, blend, material, reference,
                                                                       odd_files):
    args = {"--material": material, "--image": reference, "--blend": str(blend), "--save": "", "--whole-image": ""}
    args.update(zip(argv[::2], (a.replace("{tmp}", str(odd_files)) if a else a for a in argv[1::2])))
    if args["--material"] == "Plain":
        child = ("import bpy, sys; bpy.ops.wm.open_mainfile(filepath=sys.argv[1]); "
                 "bpy.data.materials.new('Plain').use_fake_user = True; bpy.ops.wm.save_mainfile()")
        subprocess.run([sys.executable, "-c", child, str(blend)], check=True, capture_output=True)
    before = digest(blend)
    flat = [x for key, value in args.items() if value is not None for x in ((key,) if value == "" else (key, value))]
    done = vto(*flat)
    assert done.returncode == 2
    err = done.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vto match: error: ") and message in err[0], done.stderr
    assert digest(blend) == before and sorted(p.name for p in blend.parent.iterdir() if p.suffix == ".blend") == [
        "scene.blend"]


class FakeLayout:
    """Records what a panel draws; checks every property it shows exists (draw code runs only in the UI otherwise)."""

    def __init__(self, log):
        self.log, self.enabled = log, True

    def __getattr__(self, name):  # row(), column(), box(), ...
        return lambda *args, **kwargs: FakeLayout(self.log)

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, name
        self.log.append(("prop", name))

    def prop_enum(self, data, name, value, **kwargs):
        assert value in {item.identifier for item in data.bl_rna.properties[name].enum_items}
        self.log.append(("enum", value, self.enabled))

    def label(self, text="", **kwargs):
        self.log.append(("label", text))

    def operator(self, idname, **kwargs):
        self.log.append(("operator", idname))
        return SimpleNamespace()


def test_the_fast_label_says_what_each_fast_renders():
    from blender_addon.ui.panels import quality_cost

    assert quality_cost(LIPSTICK_PRODUCT, "FAST") == "Fast: no render, milliseconds"
    assert quality_cost(HAIR_PRODUCT, "FAST") == "Fast: 3 stage passes, 0.3-1 s"  # HAIR.fit: fast_polish, seconds
    assert quality_cost(HAIR_PRODUCT, "BETTER") == "Better: 100 renders, 2-6 s"


def test_the_panels_draw_every_control_and_the_last_estimate(material, reference):
    log = []
    context = SimpleNamespace(material=bpy.data.materials[material], preferences=bpy.context.preferences,
                              scene=bpy.context.scene)
    bpy.types.VTO_PT_match_material.draw(SimpleNamespace(layout=FakeLayout(log)), context)
    shown = {entry[1] for entry in log if entry[0] == "prop"}
    assert {"image_path", "use_crop", "mask_path", "model_path"} <= shown
    assert {"find_region"} <= shown
    assert [entry[1] for entry in log if entry[0] == "enum"] == ["FAST", "BETTER"]  # LIPSTICK_PRODUCT.fit.offered
    assert ("label", LIPSTICK_PRODUCT.fit.not_offered) in log  # and it says why not Best
    assert any(entry[1] == "Fast: no render, milliseconds" for entry in log if entry[0] == "label")
    assert ("operator", "vto.match_from_photo") in log
    assert run_match(material=material, image_path=reference)[0] == {"FINISHED"}
    log.clear()
    bpy.types.VTO_PT_match_material.draw(SimpleNamespace(layout=FakeLayout(log)), context)
    labels = [entry[1] for entry in log if entry[0] == "label"]
    for name in SPEC.modelled:
        param = LIPSTICK.by_name[name]
        assert any(text.startswith(f"{param.socket}: ") and text.endswith(param.unit) for text in labels), name
    log.clear()
    hair_context = SimpleNamespace(scene=bpy.data.scenes.new("Empty Compositor"), preferences=bpy.context.preferences)
    bpy.types.VTO_PT_match_hair.draw(SimpleNamespace(layout=FakeLayout(log)), hair_context)
    assert ("operator", "vto.add_hair_compositor") in log


def test_invoke_in_background_is_execute_and_refinement_reports_progress(material, reference, tmp_path):
    assert bpy.ops.vto.match_from_photo("INVOKE_DEFAULT", material=material, image_path=reference,
                                        find_lips=False) == {"FINISHED"}
    expected = expected_estimate(load_reference(reference))
    assert {n: inputs_of(material)[n] for n in expected} == pytest.approx(expected, abs=1e-4)
    hair = get_spec("hair")
    scene = bpy.data.scenes.new("Hair Progress")
    blender_side("hair").add_group(scene)
    write_image(tmp_path / "photo.png", gradient_image(16, 16), bits=16)
    mask = np.zeros((16, 16), np.float32)
    mask[4:] = 1.0
    write_image(tmp_path / "mask.png", mask)
    seen = []
    result = apply.match_into_stage(scene, {"image_path": str(tmp_path / "photo.png"), "quality": "BETTER",
                                           "mask_path": str(tmp_path / "mask.png"), "crop": None,
                                           "model_path": tiny_encoder(tmp_path / "hair.onnx", hair)}, HAIR_PRODUCT,
                                   seen.append)
    assert seen == list(range(2, 101, 2))  # an update per step of Better's fit: 2 default regions, 100 renders
    assert hair.check_values(result["values"]) == pytest.approx(hair.full_values(result["values"]))


def test_the_modal_refinement_writes_only_at_the_end_and_esc_changes_nothing(tmp_path, monkeypatch):
    """The UI path: a few renders per timer tick, progress each render, the values written once, after the last."""
    import blender_addon.ui.operators as operators

    hair = get_spec("hair")
    scene = bpy.data.scenes.new("Hair Modal")
    blender_side("hair").add_group(scene)
    write_image(tmp_path / "photo.png", gradient_image(16, 16), bits=16)
    mask = np.zeros((16, 16), np.float32)
    mask[4:] = 1.0
    write_image(tmp_path / "mask.png", mask)
    settings = {"image_path": str(tmp_path / "photo.png"), "mask_path": str(tmp_path / "mask.png"),
                "quality": "BETTER", "model_path": tiny_encoder(tmp_path / "hair.onnx", hair)}

    class Modal:  # the operator's own methods on a stand-in (an operator cannot be made outside a running UI)
        modal, stop, done, fail = (operators.VTO_OT_match_from_photo.__dict__[k] for k in ("modal", "stop", "done",
                                                                                          "fail"))

        def __init__(self):
            self.reports, self._timer, self._stored = [], object(), scene.vto_hair_match
            self._job = apply.MatchJob("hair", settings, scene=scene)
            self._steps = self._job.steps()

        def report(self, kind, text):
            self.reports.append((set(kind), text))

    progress, ended = [], []
    manager = SimpleNamespace(progress_update=progress.append, progress_end=lambda: ended.append(True),
                              event_timer_remove=lambda timer: None)
    context = SimpleNamespace(window_manager=manager)
    monkeypatch.setattr(operators, "TICK_SECONDS", 0.0)  # one render per tick
    before = {s.name: s.default_value for n in apply.group_nodes(HAIR_PRODUCT, scene) for s in n.inputs if s.name in
              {p.socket for p in hair.params}}

    def values():
        return {s.name: s.default_value for n in apply.group_nodes(HAIR_PRODUCT, scene) for s in n.inputs if s.name in before}

    cancelled = Modal()
    assert cancelled.modal(context, SimpleNamespace(type="TIMER")) == {"RUNNING_MODAL"} and progress == [2]
    assert cancelled.modal(context, SimpleNamespace(type="MOUSEMOVE")) == {"PASS_THROUGH"}  # the UI keeps working
    assert cancelled.modal(context, SimpleNamespace(type="ESC")) == {"CANCELLED"} and ended == [True]
    assert values() == before and scene.vto_hair_match.last_estimate == ""
    progress.clear()
    running, ticks = Modal(), 0
    while (state := running.modal(context, SimpleNamespace(type="TIMER"))) == {"RUNNING_MODAL"}:
        ticks += 1
        assert values() == before  # nothing written while it runs
    assert state == {"FINISHED"} and ticks == 50 and progress == list(range(2, 101, 2))
    assert values() != before and json.loads(scene.vto_hair_match.last_estimate)["renderer"] == "hair"
    assert running.reports[-1][0] == {"INFO"} and running.reports[-1][1].startswith("matched the compositor")


def test_refinement_checks_for_other_renders_before_every_step(monkeypatch):
    """Within one timer tick the modal Match asks before each step whether Blender renders elsewhere (a preview job
    started since the tick began is seen before the next render, not a tick later)."""
    from types import SimpleNamespace

    from blender_addon.ui import operators

    taken, busy = [], iter([False, False, True])

    def steps():
        for step in range(10):
            taken.append(step)
            yield step

    modal = SimpleNamespace(_steps=steps(), stop=lambda context: None)
    manager = SimpleNamespace(progress_update=lambda value: None)
    monkeypatch.setattr(operators, "TICK_SECONDS", 60.0)  # the tick alone would take every step
    monkeypatch.setattr(operators, "another_thread_renders", lambda: next(busy))
    state = operators.VTO_OT_match_from_photo.modal(modal, SimpleNamespace(window_manager=manager),
                                                   SimpleNamespace(type="TIMER"))
    assert state == {"RUNNING_MODAL"} and taken == [0, 1]


def test_blender_jobs_waited_for_are_ones_blender_knows(monkeypatch):
    """Each job type the modal Match waits for is one bpy.app.is_job_running accepts (a misspelt one raises), in the
    background none runs, and a type a later Blender drops is passed over."""
    import bpy

    from blender_addon.ui import operators
    from blender_addon.ui.operators import BLENDER_JOBS, another_thread_renders

    assert {"RENDER_PREVIEW", "RENDER"} <= set(BLENDER_JOBS)
    assert not any(bpy.app.is_job_running(kind) for kind in BLENDER_JOBS) and not another_thread_renders()
    monkeypatch.setattr(operators, "BLENDER_JOBS", ("RENDER_PREVIEW", "A_JOB_OF_BLENDER_6"))  # one it does not have
    assert not another_thread_renders()
    with pytest.raises(ValueError, match="not found"):
        bpy.app.is_job_running("RENDER_PREVIEWS")


def test_refinement_waits_while_another_thread_renders_in_cycles(tmp_path):
    """The modal Match does not render while Cycles' Python render callbacks run in a job thread (a material
    preview): starting a render then deadlocked Blender 4.3 in a real window."""
    import importlib.util
    import threading

    from blender_addon.ui.operators import another_thread_renders

    (tmp_path / "cycles").mkdir()
    (tmp_path / "cycles" / "engine.py").write_text("def render(started, release):\n    started.set()\n"
                                                   "    release.wait(10)\n")
    spec = importlib.util.spec_from_file_location("fake_cycles_engine", tmp_path / "cycles" / "engine.py")
    engine = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(engine)
    started, release = threading.Event(), threading.Event()
    preview = threading.Thread(target=engine.render, args=(started, release))
    assert not another_thread_renders()
    preview.start()
    started.wait(10)
    try:
        assert another_thread_renders()
    finally:
        release.set()
        preview.join(10)
    assert not another_thread_renders()


# --- eye shadow: the Add VTO Material button, Match on a photo framed on one eye ----------------------------------

EYESHADOW = get_spec("eyeshadow")
TEAL = {"opacity": 0.9, "red": 40.0, "green": 120.0, "blue": 140.0}  # the look the eye photo wears


@pytest.fixture(scope="module")
def eye_photo(tmp_path_factory):
    """A portrait wearing a teal shadow on both eyes: the astronaut (public domain, NASA) with TEAL tried on, a PNG."""
    import skimage.data

    from blender_addon.renderers.tryon import tryon_product
    from vto_core.products import EYESHADOW

    path = tmp_path_factory.mktemp("eye") / "portrait.png"
    write_image(path, tryon_product(EYESHADOW, skimage.data.astronaut().astype(np.float32) / 255, TEAL, samples=2))
    return str(path)


@pytest.fixture(scope="module")
def one_eye_photo(tmp_path_factory):
    """A photo framed on one eye: the default eye scene (source 3) wearing a teal shadow, 32 px, as a PNG."""
    from blender_addon.renderers.products import render

    path = tmp_path_factory.mktemp("eye") / "eye.png"
    write_image(path, render("eyeshadow", TEAL, 3, 32, 2), bits=16)
    return str(path)


@pytest.fixture
def lid(request):
    """A mesh with a fresh "VTO Eye Shadow" material made by the generic operator; its placement set by hand."""
    obj = new_mesh(f"Lid {request.node.name}"[:60])
    assert bpy.ops.vto.add_material(product="eyeshadow") == {"FINISHED"}
    material = obj.active_material
    shadow_node(material).inputs["Height"].default_value = 0.8  # the artist's, which a photo does not fix
    return material.name


def shadow_node(material):
    if isinstance(material, str):
        material = bpy.data.materials[material]
    (node,) = apply.group_nodes(EYESHADOW_PRODUCT, material)
    return node


def shadow_inputs(material_name: str) -> dict[str, float]:
    node = shadow_node(material_name)
    return {p.name: float(node.inputs[p.socket].default_value) for p in EYESHADOW.params}


def test_add_material_adds_each_material_products_group_and_the_old_lipstick_idname_still_works(lid):
    from blender_addon.ui.operators import material_product_items

    assert [item[0] for item in material_product_items(None, bpy.context)] == [
        p.name for p in PRODUCTS.values() if p.is_material] == ["lipstick", "eyeshadow"]
    material = bpy.data.materials[lid]
    node = shadow_node(material)
    assert node.node_tree.name == "VTO Eye Shadow" and apply.material_product(material) is EYESHADOW_PRODUCT
    (output,) = [n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    assert output.inputs["Surface"].links[0].from_node == node
    assert node.inputs["Lid"].links[0].from_node.bl_idname == "ShaderNodeBsdfPrincipled"
    obj = bpy.context.view_layer.objects.active
    assert obj.active_material.name == lid and {"REGISTER", "UNDO"} <= set(bpy.types.VTO_OT_add_material.bl_options)
    assert bpy.types.VTO_OT_add_material.description(bpy.context, SimpleNamespace(product="eyeshadow")).startswith(
        'Add a "VTO Eye Shadow" material')  # the tooltip names the product
    assert bpy.ops.vto.add_material(product="lipstick") == {"FINISHED"}
    assert apply.material_product(obj.active_material) is LIPSTICK_PRODUCT
    assert bpy.ops.vto.add_lipstick_material() == {"FINISHED"}  # scripts' name from before
    assert apply.material_product(obj.active_material) is LIPSTICK_PRODUCT and len(obj.material_slots) == 3
    log = []  # the starting-point panel offers one button a material product
    bpy.types.VTO_PT_add_lipstick.draw(SimpleNamespace(layout=FakeLayout(log)), bpy.context)
    assert [entry for entry in log if entry[0] == "operator"] == [("operator", "vto.add_material")] * 2


def test_eyeshadow_match_writes_the_mean_estimate_of_both_eyes_of_a_portrait(lid, eye_photo, eyeshadow_encoder):
    """Find Region on (the default): both eyes' lids found, each framed as the default eye scene frames one and read
    with the photo's light taken out; the mean of the tiny trained encoder's two estimates lands in the group, the rest
    stays."""
    from blender_addon.matching.reference import read_reference
    from blender_addon.ui.operators import target_items

    assert EYESHADOW_PRODUCT.target_item in target_items(None, bpy.context)
    before = shadow_inputs(lid)
    assert run_match(target="EYESHADOW", material=lid, image_path=eye_photo, model_path=eyeshadow_encoder) == (
        {"FINISHED"}, None)
    after = shadow_inputs(lid)
    reference = read_reference("eyeshadow", {"image_path": eye_photo})
    assert len(reference.regions) == 2 and len(reference.images) == 2 and reference.light.read_from == "skin"
    session = EncoderSession(eyeshadow_encoder)
    assert session.spec.modelled == ("opacity", "red", "green", "blue")
    values = session.predict_views([reference.images])[0]
    expected = {name: values[name] for name in session.spec.modelled}
    assert expected != pytest.approx(expected_estimate(reference.image, eyeshadow_encoder), abs=1e-4)  # both eyes
    assert {n: after[n] for n in expected} == pytest.approx(expected, abs=1e-4)
    changed = {n for n in after if after[n] != before[n]}
    assert changed <= set(expected) and changed and after["height"] == pytest.approx(0.8)  # the rest untouched
    last = json.loads(bpy.data.materials[lid].vto_match.last_estimate)
    assert last["renderer"] == "eyeshadow" and last["values"] == pytest.approx(expected)


def test_eyeshadow_match_reads_a_photo_of_one_eye_whole_with_find_region_off(lid, one_eye_photo, eyeshadow_encoder):
    """A close-up of one eye (no face to find eyelids in): with Find Eyelids off it is read as framed, whole, its light
    as it is."""
    from blender_addon.matching.reference import read_reference

    assert run_match(target="EYESHADOW", material=lid, image_path=one_eye_photo, model_path=eyeshadow_encoder,
                     find_region=False) == ({"FINISHED"}, None)
    reference = read_reference("eyeshadow", {"image_path": one_eye_photo, "find_region": False})
    assert reference.region is None and reference.light is None
    assert np.array_equal(reference.image, load_reference(one_eye_photo))
    expected = expected_estimate(load_reference(one_eye_photo), eyeshadow_encoder)
    assert {n: shadow_inputs(lid)[n] for n in expected} == pytest.approx(expected, abs=1e-4)
    with pytest.raises(VtoError, match="^no eyelids found: no face in the image"):  # Find Eyelids on: no face to read
        read_reference("eyeshadow", {"image_path": one_eye_photo})


def test_eyeshadow_match_is_one_undo_step_and_a_failure_changes_nothing(lid, eye_photo, eyeshadow_encoder,
                                                                        tmp_path):
    before = shadow_inputs(lid)
    lipstick_model = tiny_encoder(tmp_path / "lipstick.onnx", LIPSTICK.select(["opacity", "red"]))
    for model, message in ((str(tmp_path / "none.onnx"), "no encoder model"),
                           (lipstick_model, "estimates lipstick parameters, not eyeshadow")):
        result, error = run_match(target="EYESHADOW", material=lid, image_path=eye_photo, model_path=model)
        assert result == {"CANCELLED"} and len(error.splitlines()) == 1 and message in error, error
    plain = bpy.data.materials.new("Plain Lid")
    result, error = run_match(target="EYESHADOW", material=plain.name, image_path=eye_photo,
                              model_path=eyeshadow_encoder)
    assert result == {"CANCELLED"} and "does not use the 'VTO Eye Shadow' node group" in error
    assert shadow_inputs(lid) == before and bpy.data.materials[lid].vto_match.last_estimate == ""
    bpy.ops.ed.undo_push(message="before match")
    assert run_match(target="EYESHADOW", material=lid, image_path=eye_photo,
                     model_path=eyeshadow_encoder)[0] == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Match")  # what Blender's UI does after an operator declaring UNDO
    assert shadow_inputs(lid) != before
    bpy.ops.ed.undo()
    assert shadow_inputs(lid) == before


def test_eyeshadow_preference_defaults_to_the_shipped_model_and_the_panel_says_when_one_is_missing(lid, tmp_path):
    from blender_addon.ui.preferences import VTO_AP_preferences

    setting = VTO_AP_preferences.bl_rna.properties["eyeshadow_model"]
    assert (setting.default, setting.subtype) == ("", "FILE_PATH")  # empty: the shipped one
    assert apply.resolve_model("eyeshadow") == ROOT / "blender_addon" / "models" / "eyeshadow_encoder.onnx"
    material = bpy.data.materials[lid]
    material.vto_match.model_path = str(tmp_path / "gone.onnx")
    log = []
    context = SimpleNamespace(material=material, preferences=bpy.context.preferences, scene=bpy.context.scene)
    bpy.types.VTO_PT_match_material.draw(SimpleNamespace(layout=FakeLayout(log)), context)
    labels = [entry[1] for entry in log if entry[0] == "label"]
    assert "no model file gone.onnx" in labels
    assert ("prop", "find_region") in log  # Find Eyelids: the lids are found in a whole portrait
    offered = [entry[1] for entry in log if entry[0] == "enum"]
    assert offered == list(EYESHADOW_PRODUCT.fit.offered) if len(EYESHADOW_PRODUCT.fit.offered) > 1 else offered == []
    assert ("operator", "vto.match_from_photo") in log
