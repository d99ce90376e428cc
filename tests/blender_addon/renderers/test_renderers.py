"""The Blender renderers R(X, g): node groups, sensitivity above render noise, extremes, errors, determinism."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.renderers.products import blender_side, render  # noqa: E402
from blender_addon.renderers.hair import render_hair_source, run_hair_stage  # noqa: E402
from blender_addon.renderers.product_lipstick import render_lipstick  # noqa: E402
from blender_addon.renderers.node_utils import interface_names  # noqa: E402
from blender_addon.renderers.nodes_hair import color_group, swatch_group  # noqa: E402
from blender_addon.renderers.nodes_lipstick import lipstick_group  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.imageio import read_image  # noqa: E402
from vto_core.products import get_spec, product_names  # noqa: E402

RES, SAMPLES, BLOCK = 64, 8, 8
LIPSTICK_BASE = {"opacity": 1.0, "sparkle_density": 0.5}  # makeup on, flakes present, so every input shows


def moved_value(param, current):
    """The range end farther from `current` (4.0 stands for the top of the unbounded gloss)."""
    high = param.high if param.bounded else 4.0
    if param.wraps:
        return (current + 0.5) % 1.0
    return param.low if abs(current - param.low) > abs(current - high) else high


def block_mean(image, k=BLOCK):
    """(H, W, 3) -> (H/k, W/k, 3) block averages: systematic changes survive, sampling noise shrinks."""
    h = image.shape[0] // k
    return image[: h * k, : h * k].reshape(h, k, h, k, 3).mean((1, 3))


def effect_over_noise(render_pair):
    """Change of a parameter over the render-noise floor, measured with two Cycles seeds.

    d_s = R(g'; s) - R(g; s). The effect is |d_0 + d_1| / 2, the noise floor of that change |d_0 - d_1| / 2
    (pure noise gives a ratio near 1).
    """
    d0, d1 = (block_mean(a - b) for a, b in render_pair)
    return float(np.abs(d0 + d1).mean() / max(np.abs(d0 - d1).mean(), 1e-12))


def test_lipstick_group_has_every_spec_input_with_range_and_default():
    group = lipstick_group()
    spec = get_spec("lipstick")
    assert interface_names(group) == ["Lips"] + [p.socket for p in spec.params]
    sockets = {item.name: item for item in group.interface.items_tree if item.item_type == "SOCKET"}
    for param in spec.params:
        socket = sockets[param.socket]
        assert socket.default_value == pytest.approx(param.default)
        assert socket.min_value == pytest.approx(param.low)
        assert socket.max_value == pytest.approx(param.high) if param.bounded else socket.max_value > 1e37
    assert lipstick_group() is group, "get-or-create must not duplicate the group"


def test_hair_groups_split_swatch_and_non_swatch_inputs():
    spec = get_spec("hair")
    assert interface_names(swatch_group()) == ["Image"] + [p.socket for p in spec.params if p.group == "swatch"]
    assert interface_names(color_group()) == ["Image", "Mask", "Gradient"] + [
        p.socket for p in spec.params if p.group == "non-swatch"]


def test_groups_survive_save_and_reload(tmp_path):
    lipstick_group(), swatch_group(), color_group()
    path = str(tmp_path / "groups.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    with bpy.data.libraries.load(path) as (source, target):
        target.node_groups = [n for n in source.node_groups if n.startswith("VTO")]
    loaded = {g.name.rsplit(".", 1)[0]: g for g in target.node_groups}
    assert interface_names(loaded["VTO Lipstick"]) == interface_names(lipstick_group())
    assert interface_names(loaded["VTO Hair Color"]) == interface_names(color_group())
    assert len(loaded["VTO Lipstick"].nodes) == len(lipstick_group().nodes)
    for group in target.node_groups:
        bpy.data.node_groups.remove(group)


def test_same_inputs_give_identical_pixels():
    values = {"opacity": 0.9, "red": 120.0, "gloss": 2.0}
    first = render_lipstick(values, 2, 32, 4, seed=3)
    again = render_lipstick(values, 2, 32, 4, seed=3)
    other_seed = render_lipstick(values, 2, 32, 4, seed=4)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other_seed)


# One hair render per process: what varied was set up per process (the head mesh's face order), not per render.
HAIR_HASHES = """
import hashlib, bpy
from blender_addon.renderers.hair import render_hair
print(*(hashlib.sha256(render_hair(values, 3, 24, 2).tobytes()).hexdigest() for values in ({}, {"hue": 0.3})))
"""


def test_hair_renders_repeat_exactly_across_processes():
    runs = [subprocess.run([sys.executable, "-c", HAIR_HASHES], capture_output=True, text=True, check=True)
            .stdout.splitlines()[-1].split() for _ in range(3)]
    assert runs[0] == runs[1] == runs[2]
    assert runs[0][0] != runs[0][1]  # the hashes are of the pixels: another hue gives another one


@pytest.fixture(scope="module")
def lipstick_base():
    return [render_lipstick(LIPSTICK_BASE, 1, RES, SAMPLES, seed) for seed in (0, 1)]


@pytest.mark.parametrize("param", get_spec("lipstick").params, ids=lambda p: p.name)
def test_every_lipstick_input_changes_pixels_above_render_noise(param, lipstick_base):
    values = dict(LIPSTICK_BASE)
    values[param.name] = moved_value(param, values.get(param.name, param.default))
    moved = [render_lipstick(values, 1, RES, SAMPLES, seed) for seed in (0, 1)]
    ratio = effect_over_noise(zip(moved, lipstick_base))
    assert ratio > 1.0, f"{param.name}: change/noise = {ratio:.2f}"


@pytest.mark.parametrize("param", get_spec("lipstick").params, ids=lambda p: p.name)
def test_lipstick_range_ends_render_finite(param):
    for value in (param.low, param.sample_high):
        image = render_lipstick({**LIPSTICK_BASE, param.name: value}, 0, 16, 2)
        assert np.isfinite(image).all() and 0.0 <= image.min() and image.max() <= 1.0


@pytest.fixture(scope="module")
def hair_sources():
    return [render_hair_source(1, RES, SAMPLES, seed) for seed in (0, 1)]


@pytest.mark.parametrize("param", get_spec("hair").params, ids=lambda p: p.name)
def test_every_hair_input_changes_pixels_above_render_noise(param, hair_sources):
    spec = get_spec("hair")
    base = spec.defaults()
    moved_values = {**base, param.name: moved_value(param, base[param.name])}
    pairs = [(run_hair_stage(s, moved_values), run_hair_stage(s, base)) for s in hair_sources]
    ratio = effect_over_noise(pairs)
    assert ratio > 1.0, f"{param.name}: change/noise = {ratio:.2f}"


@pytest.mark.parametrize("param", get_spec("hair").params, ids=lambda p: p.name)
def test_hair_range_ends_render_finite(param, hair_sources):
    for value in (param.low, param.high):
        image = run_hair_stage(hair_sources[0], {param.name: value})
        assert np.isfinite(image).all() and 0.0 <= image.min() and image.max() <= 1.0


def test_empty_mask_and_constant_source_are_defined(hair_sources):
    source = hair_sources[0]
    empty = type(source)(source.rgb, np.zeros_like(source.mask))
    with pytest.warns(UserWarning, match="empty"):
        unchanged = run_hair_stage(empty, {"hue": 0.5})
    assert np.abs(unchanged - source.rgb).max() < 1e-4  # no hair: nothing to recolour
    flat = type(source)(np.full_like(source.rgb, 0.4), source.mask)
    image = run_hair_stage(flat, {"saturation": 3.0})
    assert np.isfinite(image).all()


@pytest.mark.parametrize("values, message", [
    ({"shimmer": 1.0}, "unknown lipstick parameter 'shimmer'"),
    ({"opacity": 1.5}, r"outside its range \[0, 1\]"),
    ({"red": float("nan")}, "must be a number"),
])
def test_bad_lipstick_values_are_clear_errors(values, message):
    with pytest.raises(VtoError, match=message):
        render("lipstick", values, 0, 16, 1)


def test_bad_sources_are_clear_errors(tmp_path):
    with pytest.raises(VtoError, match="cannot read image"):
        render("hair", {}, str(tmp_path / "missing.png"), 16, 1)
    with pytest.raises(VtoError, match="seeds of the default lips scene"):
        render("lipstick", {}, "lips.png", 16, 1)


def test_vto_render_writes_what_the_api_renders(tmp_path, capsys):
    out = tmp_path / "hair.exr"
    params = json.dumps({"hue": 0.3, "shine": 0.5})
    assert cli.run(["render", "hair", "--params", params, "--source", "2", "--res", "32", "--samples", "4",
                    "--out", str(out)]) == 0
    written, _ = read_image(out)
    expected = render("hair", json.loads(params), 2, 32, 4)
    assert np.abs(written - expected).max() < 1e-3  # half-float EXR
    assert cli.run(["render", "hair", "--params", '{"gamma": 9}', "--out", str(tmp_path / "x.png")]) == 2
    assert not (tmp_path / "x.png").exists()
    assert "outside its range" in capsys.readouterr().err


def test_spec_ranges_cover_the_paper():
    """Table 2 and 3 ranges as the node groups expose them."""
    lipstick = get_spec("lipstick").by_name
    assert (lipstick["red"].low, lipstick["red"].high) == (0, 255)
    assert lipstick["gloss"].high == math.inf
    hair = get_spec("hair").by_name
    assert (hair["gamma"].low, hair["gamma"].high) == (0.5, 3.0)
    assert (hair["blend"].low, hair["blend"].high) == (-1.0, 1.0)


def test_a_photo_with_its_mask_is_a_hair_source(tmp_path, hair_sources):
    from blender_addon.renderers.hair import load_photo_source, photo_sources
    from vto_core.imageio import write_image

    source = hair_sources[0]
    write_image(tmp_path / "portrait.png", source.rgb, bits=16)
    write_image(tmp_path / "portrait_mask.png", source.mask)
    write_image(tmp_path / "no_mask.png", source.rgb)
    assert photo_sources(tmp_path) == [tmp_path / "portrait.png"]
    photo = load_photo_source(tmp_path / "portrait.png")
    assert np.array_equal(photo.mask, source.mask) and np.abs(photo.rgb - source.rgb).max() < 1e-4
    values = {"hue": 0.4, "saturation": 2.0}
    from_file = render("hair", values, str(tmp_path / "portrait.png"), RES, SAMPLES)
    assert np.abs(from_file - run_hair_stage(source, values)).max() < 2e-3
    assert load_photo_source(tmp_path / "portrait.png", res=32).rgb.shape == (32, 32, 3)
    with pytest.raises(VtoError, match="no mask for"):
        render("hair", values, str(tmp_path / "no_mask.png"), RES, SAMPLES)
    with pytest.raises(VtoError, match="holds no photo"):
        photo_sources(tmp_path / "empty") if (tmp_path / "empty").mkdir() is None else None


def test_the_default_hair_source_is_a_region_of_strands_and_the_portrait_a_whole_head():
    from blender_addon.renderers.hair import render_hair_source
    from blender_addon.renderers.scene_hair import POINTS_PER_STRAND, STRANDS, strand_positions

    points = strand_positions(np.random.default_rng([3, 0x4A12]))
    assert points.shape == (STRANDS * POINTS_PER_STRAND, 3) and np.isfinite(points).all()
    shares = [render_hair_source(seed, 32, 4).mask.mean() for seed in range(4)]
    assert np.median(shares) > 0.95, shares  # the close-up a patch of hair is cut from
    portrait = render_hair_source(0, 32, 4, view="portrait")
    assert 0.1 < portrait.mask.mean() < 0.7  # a head: hair, face and background
    with pytest.raises(VtoError, match="region or portrait"):
        render_hair_source(0, 16, 1, view="side")


def test_a_blender_without_openimagedenoise_renders_undenoised():
    """Debian's Blender 4.3 has no OpenImageDenoise: setting it raises TypeError, and renders go on without it."""
    from types import SimpleNamespace

    from blender_addon.renderers.cycles import set_render_quality

    class NoDenoiser(SimpleNamespace):
        def __setattr__(self, name, value):
            if name == "denoiser":
                raise TypeError('bpy_struct: item.attr = val: enum "OPENIMAGEDENOISE" not found in ()')
            super().__setattr__(name, value)

    scene = SimpleNamespace(cycles=NoDenoiser())
    set_render_quality(scene, 8, 3)
    assert scene.cycles.use_denoising is False and scene.cycles.samples == 8 and scene.cycles.seed == 3


def test_tones_replace_a_lips_sources_skin_and_lips_and_leave_its_light_and_shape():
    """render_lipstick's tones: the skin and bare lips take them (the skin reads the tone's colour), the source's
    light, shape and camera stay (the lips mask is the source's), and the next render without them is the seed's own
    again (scene_lips.source_tones says what they are)."""
    from blender_addon.renderers.scene_lips import lip_tone, lips_mask, source_tones
    from vto_core.appearance import skin_light
    from vto_core.colour import ciede2000, srgb_to_lab

    source, bare = 4, {"opacity": 0.0}
    own = render_lipstick(bare, source, 32, 8, 0)
    skin, lips = source_tones(source)
    assert np.all((0 <= skin) & (skin <= 1)) and np.all(lips < skin)  # the bare lips: darker than the skin
    pale = np.array([0.95, 0.85, 0.8])
    toned = render_lipstick(bare, source, 32, 8, 0, tones=(pale, lip_tone(pale)))
    mask = lips_mask(source, 32)
    own_skin, toned_skin = skin_light(own, mask)[1], skin_light(toned, mask)[1]
    assert toned_skin[0] > own_skin[0] + 5  # a paler skin than source 4's
    assert ciede2000(toned_skin, srgb_to_lab(pale)) < ciede2000(own_skin, srgb_to_lab(pale))
    np.testing.assert_array_equal(render_lipstick(bare, source, 32, 8, 0), own)  # its own tones again
    np.testing.assert_array_equal(own, render_lipstick(bare, source, 32, 8, 0, tones=(skin, lips)))


@pytest.mark.parametrize("name", [n for n in product_names() if blender_side(n).bare_tone_prior > 0])
def test_bare_tone_moves_the_bare_region_alone_and_puts_it_back(name):
    renderer = blender_side(name)
    bound = renderer.bind(1, 32, 4, 0)
    bare = bound.render({"opacity": 0.0})
    mask = bound.mask
    with renderer.bare_tone(0.5):  # far past a source's own draw, so the change stands far above float noise
        moved = bound.render({"opacity": 0.0})
    again = bound.render({"opacity": 0.0})
    region = np.abs(moved - bare)[mask].mean()
    outside = np.abs(moved - bare)[~mask].mean()
    assert region > 0.01, f"{name}: the bare region moved {region:.4f}"
    assert region > 5 * outside, f"{name}: the rest moved {outside:.4f} against the region's {region:.4f}"
    np.testing.assert_array_equal(again, bare)
