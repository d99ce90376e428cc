"""Add-on registration: the `vto` CLI command for `blender -b -c vto`, and a user's .blend as the lipstick scene."""

import json
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

import blender_addon  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402


def test_register_adds_the_cli_command_and_unregister_removes_it(capsys):
    blender_addon.register()
    try:
        assert blender_addon._cli_handle is not None
        assert blender_addon.run_cli(["spec", "hair", "--params", "hue"]) == 0
        assert json.loads(capsys.readouterr().out)["vector_order"] == ["hue"]
        assert blender_addon.run_cli(["spec", "nails"]) == 2
    finally:
        blender_addon.unregister()
    assert blender_addon._cli_handle is None


USER_SCENE = r'''
import bpy, sys
from blender_addon.renderers.nodes_lipstick import lipstick_group
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.name = "Product Shot"
scene.render.engine = "CYCLES"  # the scene's own engine is kept (EEVEE would need a GPU here)
bpy.ops.mesh.primitive_plane_add(size=8)
material = bpy.data.materials.new("Swatch Card")
material.use_nodes = True
nodes = material.node_tree.nodes
bare = nodes["Principled BSDF"]
bare.inputs["Base Color"].default_value = (0.05, 0.05, 0.05, 1)
group = nodes.new("ShaderNodeGroup"); group.node_tree = lipstick_group()
material.node_tree.links.new(bare.outputs[0], group.inputs["Lips"])
material.node_tree.links.new(group.outputs[0], nodes["Material Output"].inputs["Surface"])
bpy.context.object.data.materials.append(material)
bpy.ops.object.camera_add(location=(0, 0, 3)); scene.camera = bpy.context.object
world = bpy.data.worlds.new("white"); world.color = (1, 1, 1); scene.world = world
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''


def test_dataset_renders_the_users_blend_not_the_default_scene(tmp_path):
    blend = tmp_path / "user.blend"
    subprocess.run([sys.executable, "-c", USER_SCENE, str(blend)], check=True, capture_output=True)
    out = tmp_path / "ds"
    done = subprocess.run([sys.executable, "-m", "vto_core.cli", "dataset", "lipstick", "--blend", str(blend),
                           "--out", str(out), "--n", "2", "--res", "16", "--samples", "4", "--params", "red,green,blue",
                           "--quiet"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-800:]
    reader = DatasetReader(out)
    assert reader.manifest["scene"] == "Product Shot"
    sample = reader[0]
    # a white world on a dark card: the bare source is near-uniform dark, the made-up card shows the sampled colour
    assert sample.source.std() < 0.05 and sample.source.mean() < 0.35
    values = sample.record["values"]
    expected = np.array([values["red"], values["green"], values["blue"]]) / 255.0
    centre = sample.render[4:12, 4:12].reshape(-1, 3).mean(0)
    assert np.corrcoef(centre, expected)[0, 1] > 0.9


def test_dataset_refuses_a_blend_without_the_group(tmp_path):
    blend = tmp_path / "plain.blend"
    subprocess.run([sys.executable, "-c", "import bpy, sys; bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])", str(blend)],
                   check=True, capture_output=True)
    done = subprocess.run([sys.executable, "-m", "vto_core.cli", "dataset", "lipstick", "--blend", str(blend),
                           "--out", str(tmp_path / "ds"), "--n", "1"], capture_output=True, text=True)
    assert done.returncode == 2 and "VTO Lipstick" in done.stderr
    assert not (tmp_path / "ds").exists()
