"""The "VTO Eye Shadow" layer on the default eye: its inputs, finite extremes, a layer that stays on the lid, the lid
coordinate's override, repeatable bytes, and the product's Blender side."""

import numpy as np
import pytest

pytestmark = pytest.mark.blender
bpy = pytest.importorskip("bpy")

from blender_addon.renderers.product_eyeshadow import RENDERER as EYESHADOW_SIDE, render_eyeshadow  # noqa: E402
from blender_addon.renderers.node_utils import interface_names  # noqa: E402
from blender_addon.renderers.nodes_eyeshadow import eyeshadow_group  # noqa: E402
from blender_addon.renderers.products import blender_side  # noqa: E402
from blender_addon.renderers.scene_eyes import build_eye_scene, eyelid_mask  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.products import EYELIDS, get_spec  # noqa: E402

RES, SAMPLES = 24, 2
OPAQUE = {"opacity": 1.0, "height": 1.0, "softness": 0.0}  # the shadow on all the lid but its ends


def dilated(mask, pixels=2):
    """`mask` (H, W) grown by `pixels` in the 8 directions."""
    grown = mask.copy()
    for _ in range(pixels):
        padded = np.pad(grown, 1)
        grown = np.max([padded[1 + dy:1 + dy + mask.shape[0], 1 + dx:1 + dx + mask.shape[1]]
                        for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    return grown


def test_the_group_has_every_spec_input_with_its_tooltip_and_the_lid_coordinates():
    group = eyeshadow_group()
    spec = get_spec("eyeshadow")
    assert interface_names(group) == ["Lid"] + [p.socket for p in spec.params] + ["Lid Coordinate", "Lid Across"]
    sockets = {item.name: item for item in group.interface.items_tree if item.item_type == "SOCKET"}
    for param in spec.params:
        socket = sockets[param.socket]
        assert socket.description == param.description and socket.description
        assert socket.default_value == pytest.approx(param.default)
        assert (socket.min_value, socket.max_value) == pytest.approx((param.low, param.high))
    assert "'vto_lid'" in sockets["Lid Coordinate"].description and sockets["Lid Coordinate"].default_value < 0
    assert "'vto_lid_u'" in sockets["Lid Across"].description and sockets["Lid Across"].default_value < -1
    assert eyeshadow_group() is group, "get-or-create must not duplicate the group"


def test_each_parameter_at_both_ends_of_its_range_renders_finite():
    spec = get_spec("eyeshadow")
    base = {"opacity": 1.0, "shimmer": 1.0, "sparkle_density": 1.0, "metallic": 0.5}  # every layer present
    for param in spec.params:
        for end in (param.low, param.high):
            image = render_eyeshadow({**base, param.name: end}, 1, 16, 1)
            assert np.isfinite(image).all() and image.min() >= 0 and image.max() <= 1, f"{param.name} = {end}"


def test_opacity_0_is_the_bare_lid_whatever_the_shade():
    bare = render_eyeshadow({"opacity": 0.0}, 2, RES, SAMPLES)
    loud = {"opacity": 0.0, "red": 0.0, "green": 255.0, "blue": 0.0, "shimmer": 1.0, "metallic": 1.0,
            "sparkle_density": 1.0, "sparkle_intensity": 1.0, "height": 1.0, "softness": 0.0}
    np.testing.assert_allclose(render_eyeshadow(loud, 2, RES, SAMPLES), bare, atol=1e-6)


@pytest.mark.parametrize("source", [0, 3])
def test_the_shadow_stays_on_the_lid(source):
    """Opaque black against opaque white: the lid changes, the skin, eye and brow beyond it no more than another
    Cycles seed changes them (the light the lid throws onto its neighbours is in that; 2 px around the lid, the
    pixels it covers in part and the denoiser's reach, are left out)."""
    mask = eyelid_mask(source, 32)
    black, white = ({**OPAQUE, "red": v, "green": v, "blue": v} for v in (0.0, 255.0))
    first = render_eyeshadow(black, source, 32, 4)
    change = np.abs(render_eyeshadow(white, source, 32, 4) - first).mean(axis=-1)
    noise = np.abs(render_eyeshadow(black, source, 32, 4, seed=1) - first).mean(axis=-1)
    assert change[mask].mean() > 0.25, f"the lid changed only {change[mask].mean():.3f}"
    outside = ~dilated(mask)
    assert change[outside].mean() < noise[outside].mean() and np.quantile(change[outside], 0.99) < 0.05


def test_the_mask_frames_the_lid_as_the_face_region_says():
    for source in (0, 1, 2, 5):
        mask = eyelid_mask(source, 32)
        assert 0.08 < mask.mean() < 0.4, f"source {source}: the lid covers {mask.mean():.2f} of the frame"
        columns = np.nonzero(mask.any(axis=0))[0]
        assert abs((columns.max() + 1 - columns.min()) / 32 - EYELIDS.frame_share) < 0.1


def test_the_same_seed_gives_the_same_bytes():
    values = {"opacity": 0.9, "red": 90.0, "green": 40.0, "blue": 120.0, "shimmer": 0.5, "sparkle_density": 0.3}
    first = render_eyeshadow(values, 4, 16, SAMPLES, seed=3)
    render_eyeshadow({"opacity": 0.2}, 5, 16, SAMPLES, seed=1)  # another source and look in between
    assert render_eyeshadow(values, 4, 16, SAMPLES, seed=3).tobytes() == first.tobytes()


def test_the_lid_coordinate_input_overrides_the_attribute():
    """At Height 0.3 with a sharp edge, a lid coordinate of 0.9 everywhere takes the shadow off, 0 puts it everywhere
    the attribute's band left bare."""
    values = {"opacity": 1.0, "red": 255.0, "green": 0.0, "blue": 255.0, "height": 0.3, "softness": 0.0}
    bare = render_eyeshadow({"opacity": 0.0}, 1, RES, SAMPLES)
    banded = render_eyeshadow(values, 1, RES, SAMPLES)
    node = EYESHADOW_SIDE.scene_nodes(build_eye_scene())[0]
    try:
        node.inputs["Lid Coordinate"].default_value = 0.9
        off = render_eyeshadow(values, 1, RES, SAMPLES)
        node.inputs["Lid Coordinate"].default_value = 0.0
        everywhere = render_eyeshadow(values, 1, RES, SAMPLES)
    finally:
        node.inputs["Lid Coordinate"].default_value = -1.0
    mask = eyelid_mask(1, RES)
    np.testing.assert_allclose(off, bare, atol=1e-6)
    assert np.abs(everywhere - bare)[mask].mean() > np.abs(banded - bare)[mask].mean() + 0.05


def test_shift_moves_the_shadow_along_the_lid():
    """Shift 1 (outer) against -1 (inner): the outer (left) half of the lid darker, the inner half lighter."""
    values = {"opacity": 1.0, "red": 20.0, "green": 20.0, "blue": 20.0}
    outer, inner = (render_eyeshadow({**values, "shift": shift}, 1, RES, SAMPLES).mean(axis=-1) for shift in (1, -1))
    mask = eyelid_mask(1, RES)
    half = np.zeros_like(mask)
    half[:, : RES // 2] = True
    assert outer[mask & half].mean() < inner[mask & half].mean() - 0.03
    assert outer[mask & ~half].mean() > inner[mask & ~half].mean() + 0.03


def test_the_product_binds_adds_its_material_and_renders_a_dataset(tmp_path):
    side = blender_side("eyeshadow")
    bound = side.bind(2, 16, 1, 0)
    assert bound.mask.shape == (16, 16) and bound.mask.any()
    np.testing.assert_allclose(bound.source_image(), bound.render({"opacity": 0.0}), atol=0)
    assert side.is_dark({"red": 20.0, "green": 20.0, "blue": 22.0}) and not side.is_dark(
        {"red": 212.0, "green": 170.0, "blue": 80.0})
    obj = bpy.data.objects.new("Lid Test", bpy.data.meshes.new("Lid Test"))
    material = side.add_group(obj)
    assert side.nodes(material) and obj.active_material == material
    with pytest.raises(VtoError, match="mesh"):
        side.add_group(None)
    assert "VTO Eye Shadow" in side.missing_group(bpy.data.materials.new("Plain"))
    out = tmp_path / "data"
    assert cli.run(["dataset", "eyeshadow", "--out", str(out), "--n", "2", "--res", "16", "--samples", "1",
                    "--quiet", "--sensitivity", "--params", "opacity,red"]) == 0
    reader = DatasetReader(str(out))
    assert reader.spec.renderer == "eyeshadow" and len(reader) == 2
