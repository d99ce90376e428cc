"""A user's .blend as it is: its own render settings and view transform, linked inputs refused, scene-params."""

import json
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.compat import EEVEE_ENGINE  # noqa: E402
from blender_addon.renderers.product_lipstick import RENDERER as LIPSTICK_SIDE, render_lipstick  # noqa: E402
from blender_addon.datasets.dataset import DatasetJob  # noqa: E402
from blender_addon.renderers.cycles import render_user_scene  # noqa: E402
from blender_addon.renderers.scene_params import user_scene, visible_parameters  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402

# A swatch card filling the frame, lit by a white world; AgX view, 24 px, 3 samples of its own; no sparkles
# (density and intensity 0), so their size, set off its default, cannot show.
CARD_SCENE = r'''
import bpy, sys
from blender_addon.renderers.nodes_lipstick import lipstick_group
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.name = "Card"
scene.render.engine = "CYCLES"
scene.cycles.samples = 3
scene.cycles.use_denoising = False
scene.render.resolution_x = scene.render.resolution_y = 24
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "AgX"
bpy.ops.mesh.primitive_plane_add(size=8)
material = bpy.data.materials.new("Swatch Card")
material.use_nodes = True
nodes = material.node_tree.nodes
bare = nodes["Principled BSDF"]
bare.inputs["Base Color"].default_value = (0.05, 0.05, 0.05, 1)
group = nodes.new("ShaderNodeGroup"); group.name = "Makeup"; group.node_tree = lipstick_group()
group.inputs["Opacity"].default_value = 1.0
group.inputs["Gloss"].default_value = 0.0
group.inputs["Sparkle Density"].default_value = 0.0
group.inputs["Sparkle Intensity"].default_value = 0.0
group.inputs["Sparkle Size"].default_value = 0.6
material.node_tree.links.new(bare.outputs[0], group.inputs["Lips"])
material.node_tree.links.new(group.outputs[0], nodes["Material Output"].inputs["Surface"])
if len(sys.argv) > 2:  # a value node drives Metallic
    value = nodes.new("ShaderNodeValue"); value.outputs[0].default_value = 0.3
    material.node_tree.links.new(value.outputs[0], group.inputs["Metallic"])
bpy.context.object.data.materials.append(material)
bpy.ops.object.camera_add(location=(0, 0, 3)); scene.camera = bpy.context.object
world = bpy.data.worlds.new("white"); world.color = (1, 1, 1); scene.world = world
if world.node_tree:  # Blender 5 worlds always render through their nodes
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1, 1, 1, 1)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


def _make(path, *extra):
    subprocess.run([sys.executable, "-c", CARD_SCENE, str(path), *extra], check=True, capture_output=True)
    return path


@pytest.fixture(scope="module")
def card(tmp_path_factory):
    yield _make(tmp_path_factory.mktemp("card") / "card.blend")
    bpy.ops.wm.read_factory_settings(use_empty=True)  # later modules expect no .blend open, whichever tests ran


def _open(path):
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return user_scene()


def test_the_scenes_own_settings_and_view_transform_are_kept(card):
    scene = _open(card)
    image = render_lipstick({"red": 200.0, "green": 40.0, "blue": 40.0}, seed=0, res=None, samples=None, scene=scene)
    assert image.shape == (24, 24, 3)  # the scene's own resolution
    assert scene.cycles.samples == 3 and scene.view_settings.view_transform == "AgX"  # untouched
    # ... and its own 3 samples are the ones used: the same render as asking for 3, not as 1 or 12
    assert np.array_equal(render_user_scene(scene, samples=3, seed=0), image)
    for other in (1, 12):
        assert np.abs(render_user_scene(scene, samples=other, seed=0) - image).max() > 1e-3
    # pixels are read through the scene's view transform, not an output override of the image format
    output = scene.render.image_settings
    output.color_management = "OVERRIDE"
    output.view_settings.view_transform = "Standard"
    assert np.array_equal(render_user_scene(scene, seed=0), image)
    assert output.color_management == "OVERRIDE" and output.file_format == "PNG"  # put back as it was
    output.color_management = "FOLLOW_SCENE"
    scene.view_settings.view_transform = "Standard"
    standard = render_lipstick({"red": 200.0, "green": 40.0, "blue": 40.0}, seed=0, res=None, samples=None, scene=scene)
    # AgX desaturates a strong red compared with Standard: the pixels read back are the view transform's
    agx_spread = np.ptp(image.reshape(-1, 3).mean(0))
    assert np.ptp(standard.reshape(-1, 3).mean(0)) > agx_spread + 0.05
    assert render_lipstick({}, res=16, samples=2, scene=scene).shape == (16, 16, 3)  # flags override, for one render
    assert scene.render.resolution_x == 24 and scene.cycles.samples == 3


def test_unmodelled_inputs_keep_the_artists_values(card):
    scene = _open(card)
    LIPSTICK_SIDE.set_values(scene, {"red": 10.0}, fill_defaults=False)
    values = LIPSTICK_SIDE.scene_values(scene)
    assert values["red"] == 10.0 and values["opacity"] == 1.0 and values["gloss"] == 0.0  # not reset to defaults


def test_a_linked_input_is_refused_by_name_and_nothing_changes(tmp_path):
    scene = _open(_make(tmp_path / "linked.blend", "link"))
    before = LIPSTICK_SIDE.scene_values(scene)
    with pytest.raises(VtoError, match="'Metallic' of node 'Makeup' in material 'Swatch Card' is driven by a link"):
        LIPSTICK_SIDE.set_values(scene, {"red": 12.0, "metallic": 0.9}, fill_defaults=False)
    assert LIPSTICK_SIDE.scene_values(scene) == before
    assert "metallic" not in before


def test_scene_params_finds_what_the_scene_shows_and_hides(card, capsys):
    assert cli.run(["scene-params", "--blend", str(card)]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    rows = {row["name"]: row for row in lines[:-1]}
    for name in ("opacity", "red", "green", "blue"):
        assert rows[name]["visible"], rows[name]
    for name in ("sparkle_density", "sparkle_size", "sparkle_red", "sparkle_intensity"):  # no flakes: nothing to see
        assert not rows[name]["visible"], rows[name]
        # the very same image: every other input stays at the scene's value (none is left moved by its measurement)
        assert rows[name]["ratio"] == pytest.approx(1.0, abs=1e-6)
    assert lines[-1]["params"].split(",") == lines[-1]["visible"]
    assert LIPSTICK_SIDE.scene_values(user_scene())["red"] == pytest.approx(170.0)  # the scene's values are put back


def test_scene_params_uses_the_open_file_and_checks_the_material(card, capsys):
    _open(card)  # as under `blender -b card.blend -c vto scene-params`
    assert cli.run(["scene-params", "--material", "Lips"]) == 2
    assert "material 'Lips' does not use the 'VTO Lipstick' node group" in capsys.readouterr().err
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert cli.run(["scene-params"]) == 2
    assert "give --blend FILE" in capsys.readouterr().err


def test_dataset_params_auto_models_the_visible_inputs(card, tmp_path):
    _open(card)
    rows = visible_parameters(user_scene())
    visible = [row["name"] for row in rows if row["visible"]]
    out = tmp_path / "ds"
    assert cli.run(["dataset", "lipstick", "--blend", str(card), "--params", "auto", "--out", str(out), "--n", "1",
                    "--quiet"]) == 0
    manifest = DatasetReader(out).manifest
    assert manifest["params"] == visible
    assert manifest["res"] == [24, 24] and manifest["samples"] == 3
    assert set(manifest["fixed_values"]) == {row["name"] for row in rows} - set(visible)
    assert manifest["fixed_values"]["sparkle_density"] == 0.0
    assert manifest["fixed_values"]["sparkle_size"] == pytest.approx(0.6)  # the scene's, not the default 0.3
    assert manifest["linked_inputs"] == [] and "'AgX'" in manifest["images"]
    sample = DatasetReader(out)[0]
    assert sample.render.shape == sample.source.shape == (24, 24, 3)
    assert sample.record["values"]["sparkle_size"] == pytest.approx(0.6)
    assert sorted(sample.record["values"]) == sorted(visible + list(manifest["fixed_values"]))


def test_the_manifest_records_linked_inputs_and_an_eevee_scenes_samples(tmp_path):
    scene = _open(_make(tmp_path / "linked.blend", "link"))
    manifest = DatasetJob("lipstick", str(tmp_path / "ds"), 1, res=None, samples=None, params=["red"],
                          scene=scene.name).manifest()
    assert manifest["linked_inputs"] == ["metallic"] and "metallic" not in manifest["fixed_values"]
    assert manifest["samples"] == 3 and manifest["engine"] == "CYCLES"
    scene.render.engine = EEVEE_ENGINE
    scene.eevee.taa_render_samples = 5
    assert DatasetJob("lipstick", str(tmp_path / "ds"), 1, res=None, samples=None, params=["red"],
                      scene=scene.name).manifest()["samples"] == 5
    scene.render.engine = "BLENDER_WORKBENCH"
    with pytest.raises(VtoError, match="BLENDER_WORKBENCH, which has no sample count"):
        render_user_scene(scene, samples=4)


def test_params_auto_needs_a_blend(tmp_path, capsys):
    bpy.ops.wm.read_factory_settings(use_empty=True)  # no .blend open: the default scene
    assert cli.run(["dataset", "lipstick", "--params", "auto", "--out", str(tmp_path / "x"), "--n", "1"]) == 2
    assert "--params auto needs --blend" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
