"""A product is a unit: a third, toy product declared here (the lips region, a four-input spec over the VTO Lipstick
group), with no other module edited, renders a dataset, trains and exports a tiny encoder, is matched from a portrait
(Fast) into a material, and shows in the Match operator's target list."""

import json
from dataclasses import replace

import numpy as np
import pytest

pytestmark = [pytest.mark.blender, pytest.mark.torch, pytest.mark.slow]
bpy = pytest.importorskip("bpy")
pytest.importorskip("torch")

import blender_addon  # noqa: E402
from blender_addon.matching import apply  # noqa: E402
from blender_addon.renderers.product_lipstick import LipstickRenderer  # noqa: E402
from blender_addon.renderers.products import blender_side  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402
from vto_core.imageio import write_image  # noqa: E402
from vto_core.products import LIPSTICK, PRODUCTS, FitPolicy, declare  # noqa: E402
from vto_core.specs import RendererSpec  # noqa: E402

NAMES = ("opacity", "red", "green", "blue")
TOY = replace(LIPSTICK, name="toy", label="Toy", target="TOY", blender_module=__name__,
              spec=RendererSpec("toy", tuple(p for p in LIPSTICK.spec.params if p.name in NAMES), NAMES),
              fit=FitPolicy(renders={"BETTER": (1, 4), "BEST": (1, 8)}, seconds={}, offered=("FAST",)),
              user_scenes=False, photo_datasets=False, tryon=False, asset_library=False, mouth_views=False)


class ToyRenderer(LipstickRenderer):
    """The toy's Blender side: the lipstick's, for the toy's inputs."""

    product = TOY


RENDERER = ToyRenderer()


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """The toy declared (its presets written beside the test's files), then taken back out of the registry."""
    folder = tmp_path_factory.mktemp("toy")
    presets = folder / "toy.json"
    presets.write_text(json.dumps({"renderer": "toy", "presets": [
        {"name": "Red", "params": {"opacity": 0.9, "red": 200, "green": 30, "blue": 40}},
        {"name": "Nude", "params": {"opacity": 0.6, "red": 190, "green": 120, "blue": 110}},
        {"name": "Plum", "params": {"opacity": 0.8, "red": 90, "green": 30, "blue": 70}}]}))
    product = declare(replace(TOY, presets=str(presets)))
    yield product, folder
    del PRODUCTS["toy"]


def test_a_toy_product_renders_trains_matches_and_is_a_target(toy, tiny_trained_encoder):
    product, folder = toy
    # a dataset sample, through the `vto dataset` command
    data = folder / "data"
    assert cli.run(["dataset", "toy", "--out", str(data), "--n", "4", "--res", "16", "--samples", "2",
                    "--quiet"]) == 0
    reader = DatasetReader(str(data))
    assert reader.spec.renderer == "toy" and reader.spec.modelled == NAMES and len(reader) == 4
    # a tiny encoder, trained on it and exported
    model = tiny_trained_encoder(data, folder / "encoder")
    # Match Fast from a portrait, written into a material's group
    import skimage.data

    portrait = folder / "astronaut.png"
    write_image(portrait, skimage.data.astronaut().astype(np.float32) / 255)
    blender_addon.register()
    try:
        obj = bpy.data.objects.new("Toy Lips", bpy.data.meshes.new("Toy Lips"))
        bpy.context.scene.collection.objects.link(obj)
        material = blender_side("lipstick").add_group(obj)
        result = apply.MatchJob("toy", {"image_path": str(portrait), "model_path": str(model)},
                                material_name=material.name)
        assert result.product is product and result.prepared["reference"].lips is not None  # the lips found
        written = result.finish(apply.drain(result.steps()))
        node = apply.group_nodes(product, material)[0]
        assert set(written["values"]) == set(NAMES)
        for name in NAMES:
            socket = node.inputs[product.spec.by_name[name].socket]
            assert socket.default_value == pytest.approx(written["values"][name], abs=1e-4)
        # the Match operator lists it among its targets, and runs on it
        from blender_addon.ui.operators import target_items

        targets = [item[0] for item in target_items(None, bpy.context)]
        assert "TOY" in targets and targets[:2] == ["MATERIAL", "HAIR"], targets
        assert bpy.ops.vto.match_from_photo(target="TOY", material=material.name, image_path=str(portrait),
                                            model_path=str(model)) == {"FINISHED"}
    finally:
        blender_addon.unregister()
