"""Portrait lighting in Blender: a grey card facing the camera reads what the metering asked for, in neutral light."""

import math

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from vto_core.envlight import LUMINANCE  # noqa: E402
from vto_core.portrait_light import FACING, irradiance, portrait_light  # noqa: E402

ALBEDO = 0.5


@pytest.fixture(scope="module")
def card_scene():
    """A diffuse grey card facing +z under the default scenes' world, seen by a camera looking down -z."""
    from blender_addon.compat import enable_nodes
    from blender_addon.renderers.lighting import build_hdri_world

    scene = bpy.data.scenes.new("VTO Card Test")
    mesh = bpy.data.meshes.new("VTO Card")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    material = bpy.data.materials.new("VTO Card")
    enable_nodes(material)
    nodes = material.node_tree.nodes
    for node in list(nodes):
        if node.bl_idname != "ShaderNodeOutputMaterial":
            nodes.remove(node)
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (ALBEDO, ALBEDO, ALBEDO, 1.0)
    material.node_tree.links.new(diffuse.outputs[0], nodes["Material Output"].inputs["Surface"])
    mesh.materials.append(material)
    card = bpy.data.objects.new("VTO Card", mesh)
    scene.collection.objects.link(card)
    camera = bpy.data.objects.new("VTO Card Camera", bpy.data.cameras.new("VTO Card Camera"))
    camera.location = (0.0, 0.0, 3.0)
    camera.data.lens = 200.0  # the card fills the frame
    scene.collection.objects.link(camera)
    scene.camera = camera
    build_hdri_world(scene)
    yield scene
    bpy.data.scenes.remove(scene)


@pytest.mark.parametrize("seed", [0, 1, 2, 5])
def test_a_grey_card_reads_the_metered_level_in_neutral_light(card_scene, seed):
    from blender_addon.renderers import lighting
    from blender_addon.renderers.cycles import configure_cycles, render_passes

    lighting.randomise_portrait(card_scene, np.random.default_rng(seed))
    # the same draw again, outside Blender: which map, then the lighting made of it
    rng = np.random.default_rng(seed)
    paths = [p for p in lighting.hdri_paths() if p.rsplit("/", 1)[-1] in lighting.PORTRAIT_HDRIS]
    _, lights, residual = lighting._split(paths[rng.integers(len(paths))])
    light = portrait_light(residual, list(lights), rng)
    falling = irradiance(residual, list(lights), light.rotation, FACING, light.fill) * light.tint * light.strength
    configure_cycles(card_scene, 8, 256, 0)
    card_scene.cycles.use_denoising = False
    seen = render_passes(card_scene)["Combined"][..., :3].reshape(-1, 3).mean(axis=0)
    expected = ALBEDO * falling / math.pi
    assert float(seen @ LUMINANCE) == pytest.approx(float(expected @ LUMINANCE), rel=0.05)
    assert seen / seen[1] == pytest.approx(expected / expected[1], abs=0.03)  # neutral up to the warm/cool shift


def test_portrait_lighting_shows_a_shade_alike_on_every_source():
    """The lips' mean colour varies from source to source far less under portrait light than under wide light."""
    from blender_addon.renderers.product_lipstick import render_lipstick
    from blender_addon.renderers.scene_lips import lips_mask
    from vto_core.presets import load_presets

    presets = load_presets("lipstick")
    spread = {}
    for lighting in ("wide", "portrait"):
        seen = []
        for look in ("Classic Red", "Bare Nude"):
            colours = []
            for source in range(8):
                image = render_lipstick(presets[look], source, 32, 4, 0, lighting=lighting)
                colours.append(image[lips_mask(source, 32, lighting)].mean(axis=0))
            seen.append(np.std(colours, axis=0).mean())
        spread[lighting] = float(np.mean(seen)) * 255
    assert spread["portrait"] < 0.8 * spread["wide"], spread


def test_a_lighting_that_does_not_exist_is_one_line():
    from blender_addon.renderers.scene_build import use_lighting
    from blender_addon.renderers.scene_lips import build_lips_scene
    from vto_core.errors import VtoError

    with pytest.raises(VtoError, match="lighting is wide or portrait, got 'studio'"):
        use_lighting(build_lips_scene(), "studio")


def test_the_commands_take_a_lighting_and_the_dataset_records_it(tmp_path, capsys):
    from vto_core import cli
    from vto_core.dataset import read_manifest
    from vto_core.imageio import read_image

    for lighting in ("wide", "portrait"):
        assert cli.run(["render", "lipstick", "--params", "preset:Classic Red", "--source", "4", "--res", "16",
                        "--samples", "2", "--lighting", lighting, "--out", str(tmp_path / f"{lighting}.png")]) == 0
    wide, portrait = (read_image(tmp_path / f"{name}.png")[0] for name in ("wide", "portrait"))
    assert np.abs(wide - portrait).mean() > 0.02  # another light on the same lips
    assert cli.run(["render", "lipstick", "--params", "preset:Classic Red", "--source", "4", "--res", "16",
                    "--samples", "2", "--out", str(tmp_path / "default.png")]) == 0
    assert np.array_equal(read_image(tmp_path / "default.png")[0], portrait)  # portrait is the default
    capsys.readouterr()
    assert cli.run(["render", "hair", "--params", "{}", "--lighting", "wide", "--out", str(tmp_path / "h.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "keep their own" in err[0] and not (tmp_path / "h.png").exists()
    assert cli.run(["dataset", "lipstick", "--out", str(tmp_path / "data"), "--n", "1", "--res", "16", "--samples",
                    "2", "--lighting", "wide", "--quiet"]) == 0
    assert read_manifest(tmp_path / "data")["lighting"] == "wide"


@pytest.mark.parametrize("name", ["lipstick", "eyeshadow"])
def test_turned_light_turns_and_fills_the_sources_light_and_puts_it_back(name):
    from blender_addon.renderers.lighting import turned_light
    from blender_addon.renderers.products import blender_side
    from vto_core.portrait_light import axis_angle

    renderer = blender_side(name)
    bound = renderer.bind(1, 32, 4, 0)
    look = {"opacity": 1.0, "red": 120.0, "green": 60.0, "blue": 70.0}
    before = bound.render(look)
    scene = renderer.default_scene()
    with turned_light(scene, np.eye(3)):
        unturned = bound.render(look)
    with turned_light(scene, axis_angle(np.array([0.0, 1.0, 0.0]), math.pi / 2)):  # the key from the side
        turned = bound.render(look)
    with turned_light(scene, np.eye(3), fill=3.0):
        filled = bound.render(look)
    after = bound.render(look)
    np.testing.assert_allclose(unturned, before, atol=2e-3)
    assert np.abs(turned - before).mean() > 0.02
    assert filled.mean() > before.mean() + 0.01  # more of the map's soft light
    np.testing.assert_array_equal(after, before)
