"""A product is a unit: a fourth product declared here, a face layer on the cheeks (a region no product uses), with its
own node group, default scene and Blender side built from the shared face-layer parts, and no other module edited:
it renders, samples a dataset, trains and exports a tiny encoder, is matched from a portrait (Fast) into a material,
shows in the Match operator's target list, and the eye shadow, which reads the bare lid from the cheek under the eye,
says that a layer is worn there."""

import json
from dataclasses import replace

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.torch, pytest.mark.slow]
bpy = pytest.importorskip("bpy")
pytest.importorskip("torch")

import blender_addon  # noqa: E402
from blender_addon.compat import enable_nodes  # noqa: E402
from blender_addon.matching import apply  # noqa: E402
from blender_addon.renderers.face_layer import DefaultScene, FaceLayerRenderer, LayerGroup  # noqa: E402
from blender_addon.renderers.node_utils import srgb_colour  # noqa: E402
from blender_addon.renderers.products import blender_side, render  # noqa: E402
from blender_addon.renderers.scene_build import (REGION_PASS_INDEX, SKIN_TONES, applied, finish_scene,  # noqa: E402
                                                 grid_faces, mesh_object, randomise_light, record_source, region_mask)
from vto_core import cli  # noqa: E402
from vto_core.colour import srgb_to_linear  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402
from vto_core.imageio import write_image  # noqa: E402
from vto_core.products import (EYESHADOW, FACE_LAYER, LIPSTICK, PRODUCTS, FaceRegion, FitPolicy, Product,  # noqa: E402
                               declare, frozen, layered_over_bare_skin)
from vto_core.specs import RendererSpec  # noqa: E402

NAMES = ("opacity", "red", "green", "blue")
# The subject's right cheek: the face mesh's ring from under the eye down to the cheekbone (MediaPipe indices).
CHEEKS = FaceRegion("cheeks", ((116, 117, 118, 101, 36, 205, 187, 123),), 0.8, min_width=8)
TOY = Product("toy", "Toy Blush", RendererSpec("toy", tuple(p for p in LIPSTICK.spec.params if p.name in NAMES), NAMES),
              FACE_LAYER, "cheeks", (CHEEKS,),
              FitPolicy(renders=frozen({"BETTER": (1, 4), "BEST": (1, 8)}), seconds=frozen({}), offered=("FAST",)),
              "TOY", "'VTO Toy Blush' group", __name__, coverage="opacity", look=frozen({"opacity": 1.0}))


def toy_layer(b, gin):
    """(coverage, the blush's shader): Opacity over a matte Principled BSDF of the Red/Green/Blue colour."""
    shader = b.node("BsdfPrincipled", label="Blush")
    b.link(srgb_colour(b, gin, ("Red", "Green", "Blue"), "Blush Colour").outputs[0], shader.inputs["Base Color"])
    b.link(0.7, shader.inputs["Roughness"])
    return gin["Opacity"], shader.outputs[0]


TOY_GROUP = LayerGroup("VTO Toy Blush", lambda: TOY.spec, "Cheek", "The cheek's own shader", toy_layer, None,
                       "Opacity", "Bare Cheek", (0.6, 0.4, 0.35, 1.0), 0.5)
SCENE, CHEEK, SKIN = "VTO Toy Cheek", "VTO Toy Cheek", "VTO Toy Skin"


def surface(x, y):
    """The cheek's curve: z of the skin at x, y."""
    return -0.08 * (x**2 + y**2)


def grid(half: float, count: int, lift: float = 0.0) -> np.ndarray:
    """A (count + 1)^2 vertex grid over [-half, half]^2 on the surface, `lift` above it: (N, 3)."""
    xx, yy = np.meshgrid(np.linspace(-half, half, count + 1), np.linspace(-half, half, count + 1))
    return np.stack([xx, yy, surface(xx, yy) + lift], -1).reshape(-1, 3).astype(np.float32)


def build_cheek_scene():
    """Get or create the toy's default scene: a patch of cheek (the layer's object) on a curved skin."""
    scene = bpy.data.scenes.get(SCENE)
    if scene is not None:
        return scene
    scene = bpy.data.scenes.new(SCENE)
    skin_material = bpy.data.materials.new(f"{SKIN} Material")
    enable_nodes(skin_material)
    mesh_object(scene, SKIN, grid(1.6, 24), grid_faces(24, 24), skin_material)
    cheek = mesh_object(scene, CHEEK, grid(0.85, 12, 0.01), grid_faces(12, 12), TOY_GROUP.material(f"{CHEEK} Material"))
    cheek.pass_index = REGION_PASS_INDEX
    return finish_scene(scene, "VTO Toy Camera", 50.0, None, apply_source)


def apply_source(scene, source_seed, tones=None, light_seed=None):
    """A source: a skin tone, a light and a camera jitter drawn from `source_seed`."""
    rng = np.random.default_rng([int(source_seed), 0xC4EE])
    tone = (*srgb_to_linear(np.array(SKIN_TONES[rng.integers(len(SKIN_TONES))]) / 255.0), 1.0)
    bpy.data.materials[f"{SKIN} Material"].node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = tone
    nodes = bpy.data.materials[f"{CHEEK} Material"].node_tree.nodes
    nodes[TOY_GROUP.bare_node].inputs["Base Color"].default_value = tone
    randomise_light(scene, rng)
    scene.camera.location = (rng.normal(0, 0.05), rng.normal(0, 0.05), 3.0)
    record_source(scene, source_seed, tones, light_seed)


class ToyRenderer(FaceLayerRenderer):
    """The toy's Blender side: the shared face layer's, with its own group and scene."""

    product = TOY
    layer_group = TOY_GROUP
    scene = DefaultScene(build_cheek_scene, apply_source)


RENDERER = ToyRenderer()


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """The toy declared (its presets written beside the test's files), then taken back out of the registry."""
    folder = tmp_path_factory.mktemp("toy")
    presets = folder / "toy.json"
    presets.write_text(json.dumps({"renderer": "toy", "presets": [
        {"name": "Rose", "params": {"opacity": 0.6, "red": 220, "green": 90, "blue": 110}},
        {"name": "Peach", "params": {"opacity": 0.5, "red": 240, "green": 150, "blue": 110}},
        {"name": "Berry", "params": {"opacity": 0.8, "red": 150, "green": 40, "blue": 80}}]}))
    product = declare(replace(TOY, presets=str(presets)))
    RENDERER.product = product
    yield product, folder
    del PRODUCTS["toy"]
    RENDERER.product = TOY


def test_a_cheek_product_renders_trains_matches_and_is_a_target(toy, tiny_trained_encoder):
    product, folder = toy
    # it renders: the blush shows on the cheek, in proportion to its opacity, and nowhere else
    spec = product.spec
    bare, worn = (render("toy", spec.full_values({"opacity": o, "red": 40, "green": 200, "blue": 60}), 1, 24, 4)
                  for o in (0.0, 1.0))
    mask = RENDERER.scene.mask(1, 24)
    assert 0.2 < mask.mean() < 0.8
    assert (worn - bare)[mask][:, 1].mean() > 0.3 and np.abs(worn - bare)[~mask].mean() < 0.03  # edges anti-aliased
    # a dataset sample, through the `vto dataset` command
    data = folder / "data"
    assert cli.run(["dataset", "toy", "--out", str(data), "--n", "4", "--res", "16", "--samples", "2",
                    "--quiet"]) == 0
    reader = DatasetReader(str(data))
    assert reader.spec.renderer == "toy" and reader.spec.modelled == NAMES and len(reader) == 4
    # a tiny encoder, trained on it and exported
    model = tiny_trained_encoder(data, folder / "encoder")
    # Match Fast from a portrait: the cheek found by the face mesh, the estimate written into a material's group
    import skimage.data

    portrait = folder / "astronaut.png"
    write_image(portrait, skimage.data.astronaut().astype(np.float32) / 255)
    blender_addon.register()
    try:
        obj = bpy.data.objects.new("Toy Face", bpy.data.meshes.new("Toy Face"))
        bpy.context.scene.collection.objects.link(obj)
        material = blender_side(product).add_group(obj)
        assert apply.material_product(material) is product
        result = apply.MatchJob("toy", {"image_path": str(portrait), "model_path": str(model)},
                                material_name=material.name)
        found = result.prepared["reference"].found
        assert result.product is product and found is not None and found.how == "face"
        written = result.finish(apply.drain(result.steps()))
        node = apply.group_nodes(product, material)[0]
        assert set(written["values"]) == set(NAMES)
        for name in NAMES:
            socket = node.inputs[product.spec.by_name[name].socket]
            assert socket.default_value == pytest.approx(written["values"][name], abs=1e-4)
        # the Match operator lists it among its targets, and runs on it
        from blender_addon.ui.operators import target_items

        targets = [item[0] for item in target_items(None, bpy.context)]
        assert targets == [p.target for p in PRODUCTS.values()] and "TOY" in targets, targets
        assert bpy.ops.vto.match_from_photo(target="TOY", material=material.name, image_path=str(portrait),
                                            model_path=str(model)) == {"FINISHED"}
    finally:
        blender_addon.unregister()
    # the eye shadow's Better guesses the bare lid from the cheek under the eye: a layer there is named in one line
    (line,) = layered_over_bare_skin(EYESHADOW)
    assert "Toy Blush" in line and "cheek under the right eye" in line
    from blender_addon.matching.match import match

    model = str(apply.default_model(EYESHADOW.name))
    better = match(model, str(portrait), quality="better")
    assert line in better["notes"] and line not in match(model, str(portrait))["notes"]
