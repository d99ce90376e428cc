"""Parameter specs: selection order, normalisation at the range ends, clamping and wrapping."""

import json
import math
import sys
import warnings

import numpy as np
import pytest
from hypothesis import given, strategies as st

from vto_core.errors import VtoError
from vto_core.products import PRODUCTS, get_spec
from vto_core.specs import ParamSpec, RendererSpec

ALL_PARAMS = [(r, p) for r, spec in ((name, product.spec) for name, product in PRODUCTS.items()) for p in spec.params]
IDS = [f"{r}.{p.name}" for r, p in ALL_PARAMS]


def test_builtin_sizes_match_the_paper():
    lipstick, hair = get_spec("lipstick"), get_spec("hair")
    assert len(lipstick.params) == 17
    assert lipstick.modelled == ("opacity", "red", "green", "blue", "gloss", "reflection")
    assert set(lipstick.left_out()) == {p.name for p in lipstick.params[7:]} | {"gloss_roughness"}  # below the bar
    assert all("above render noise" in why for why in lipstick.left_out().values())
    assert get_spec("lipstick", [p.name for p in lipstick.params]).size == 17  # still selectable by name
    assert len(hair.params) == 9 and hair.size == 7  # a photo fixes intensity and blend: full effect, all the hair
    assert set(hair.left_out()) == {"intensity", "blend"}
    assert hair.full_values({})["intensity"] == 1.0 and hair.full_values({})["blend"] == -1.0
    assert {p.group for p in hair.params} == {"swatch", "non-swatch"}
    assert [p.name for p in hair.params if p.group == "swatch"] == [
        "brightness", "contrast", "exposure", "gamma", "hue", "saturation"]


def test_eye_shadow_models_the_product_and_leaves_its_placement_to_the_artist():
    spec = get_spec("eyeshadow")
    assert len(spec.params) == 17 and len({p.socket for p in spec.params}) == 17
    assert spec.modelled == ("opacity", "red", "green", "blue", "shimmer", "shimmer_roughness", "shimmer_tint",
                             "sparkle_density", "metallic")
    left_out = spec.left_out()
    assert {name for name, why in left_out.items() if "the artist sets it" in why} == {"height", "softness", "shift"}
    assert {name for name, why in left_out.items() if "under the visibility bar" in why} == {
        "sparkle_size", "sparkle_intensity", "sparkle_red", "sparkle_green", "sparkle_blue"}
    assert {p.group for p in spec.params} == {"product", "placement"}
    assert all(p.description and p.bounded for p in spec.params)
    assert spec.by_name["shift"].low == -1.0 and spec.by_name["shift"].default == 0.0
    assert [p.socket for p in spec.params][:4] == ["Opacity", "Red", "Green", "Blue"]  # as the lipstick's


def test_select_keeps_spec_order_whatever_the_request_order():
    spec = get_spec("lipstick", "gloss,red,opacity")
    assert spec.modelled == ("opacity", "red", "gloss")
    assert get_spec("lipstick", ["red", "gloss", "opacity"]).modelled == spec.modelled


def test_select_unknown_or_empty_is_an_error():
    with pytest.raises(VtoError, match="unknown lipstick parameter"):
        get_spec("lipstick", "red,shimmer")
    with pytest.raises(VtoError, match="at least one"):
        get_spec("hair").select([])
    with pytest.raises(VtoError, match="unknown renderer"):
        get_spec("eyeliner")


@pytest.mark.parametrize("renderer,param", ALL_PARAMS, ids=IDS)
def test_both_range_ends_round_trip_finitely(renderer, param):
    for raw in (param.low, param.sample_high):
        unit = param.to_unit(raw)
        back = param.from_unit(unit)
        assert 0.0 <= unit <= 1.0 and math.isfinite(back)
        if param.wraps:
            assert back == pytest.approx(param.low)  # the top of a wrapping range is its bottom
        else:
            assert back == pytest.approx(raw, rel=1e-6)
    assert math.isfinite(param.from_unit(0.0)) and math.isfinite(param.from_unit(1.0))


@pytest.mark.parametrize("huge", [8.0, 100.0, 1e30, sys.float_info.max, math.inf])
def test_unbounded_gloss_encodes_up_to_its_sampling_top(huge):
    gloss = get_spec("lipstick").by_name["gloss"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        unit = gloss.to_unit(huge)
    assert unit == 1.0
    assert gloss.from_unit(unit) == gloss.unit_high == 8.0  # a decoded estimate is never absurd
    assert gloss.from_unit(5.0) == 8.0 and gloss.sample_high == 8.0


def test_saturating_map_values():
    """u = (s(g) / s(8)) ** 0.8 with s(g) = g / (g + 1): resolution where the presets are, 8 (twice the glossiest) at 1."""
    gloss = get_spec("lipstick").by_name["gloss"]
    assert gloss.unit_power == 0.8
    assert gloss.to_unit(0.0) == 0.0
    assert gloss.to_unit(1.0) == pytest.approx((0.5 / (8 / 9)) ** 0.8)
    assert gloss.from_unit(0.75 ** 0.8) == pytest.approx(2.0)
    assert gloss.from_unit(0.25 ** 0.8) == pytest.approx(2 / 7)
    values = [gloss.from_unit(u) for u in np.linspace(0, 1, 101)]
    assert np.all(np.diff(values) > 0)


def test_unit_power_widens_the_low_end_and_round_trips():
    """reflection's unit is r ** 0.85: a quarter of the encoded range reaches below r = 0.25, and back is exact."""
    reflection = get_spec("lipstick").by_name["reflection"]
    assert reflection.from_unit(0.25) == pytest.approx(0.25 ** (1 / 0.85)) and reflection.from_unit(0.25) < 0.25
    for raw in np.linspace(0.0, 1.0, 11):
        assert reflection.from_unit(reflection.to_unit(raw)) == pytest.approx(raw, abs=1e-12)
    assert reflection.to_unit(0.0) == 0.0 and reflection.to_unit(1.0) == 1.0


@pytest.mark.parametrize("power", [0.0, -1.0, math.inf, math.nan])
def test_unit_power_must_be_positive_and_finite(power):
    with pytest.raises(VtoError, match="unit_power"):
        ParamSpec("x", "X", 0.0, 1.0, 0.5, unit_power=power)


def test_a_wrapping_parameter_keeps_unit_power_1():
    with pytest.raises(VtoError, match="wrapping"):
        ParamSpec("hue", "Hue", 0.0, 1.0, 0.0, wraps=True, unit_power=0.8)


def test_a_spec_written_before_unit_power_reads_as_power_1():
    """Models and datasets made before the field existed decode as they were trained."""
    data = get_spec("lipstick").to_dict()
    for entry in data["params"]:
        del entry["unit_power"]
    old = RendererSpec.from_dict(data)
    assert old.by_name["gloss"].unit_power == 1.0 and old.by_name["gloss"].from_unit(0.75) == pytest.approx(2.0)
    assert not old.same_as(get_spec("lipstick")) and old.same_values(get_spec("lipstick"))
    assert not old.same_values(get_spec("lipstick", "red,green")) and not old.same_values(get_spec("hair"))


def test_out_of_range_is_clamped_with_a_warning_not_wrapped():
    opacity = get_spec("lipstick").by_name["opacity"]
    with pytest.warns(UserWarning, match="outside"):
        assert opacity.clamp(1.7) == 1.0
    with pytest.warns(UserWarning, match="outside"):
        assert opacity.to_unit(-0.5) == 0.0


def test_hue_wraps_silently():
    hue = get_spec("hair").by_name["hue"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert hue.clamp(1.25) == pytest.approx(0.25)
        assert hue.clamp(-0.25) == pytest.approx(0.75)
        assert hue.to_unit(1.0) == 0.0
        assert hue.from_unit(1.3) == pytest.approx(0.3)


def test_nan_is_rejected():
    spec = get_spec("hair")
    with pytest.raises(VtoError, match="NaN"):
        spec.by_name["gamma"].clamp(float("nan"))
    with pytest.raises(VtoError, match="NaN"):
        spec.denormalise(np.full(spec.size, np.nan))


@given(st.lists(st.floats(0, 1), min_size=7, max_size=7))
def test_unit_round_trip_hair(unit):
    spec = get_spec("hair")
    back = spec.normalise(spec.denormalise(np.array(unit)))
    expected = np.array(unit)
    hue = spec.modelled.index("hue")
    expected[hue] %= 1.0
    assert np.allclose(back, expected, atol=1e-5) or abs(abs(back[hue] - expected[hue]) - 1) < 1e-5


@given(st.lists(st.floats(0, 1), min_size=17, max_size=17))
def test_unit_round_trip_lipstick(unit):
    spec = get_spec("lipstick", [p.name for p in get_spec("lipstick").params])
    assert np.allclose(spec.normalise(spec.denormalise(np.array(unit))), unit, atol=1e-5)


def test_vector_and_values_fill_defaults_for_unmodelled():
    spec = get_spec("lipstick", "red,gloss")
    vec = spec.vector({"red": 10.0})
    assert vec.tolist() == [10.0, spec.by_name["gloss"].default]
    full = spec.values([20.0, 2.0])
    assert full["red"] == 20.0 and full["gloss"] == 2.0
    assert full["sparkle_density"] == spec.by_name["sparkle_density"].default and len(full) == 17
    with pytest.raises(VtoError, match="models 2"):
        spec.values([1.0, 2.0, 3.0])
    with pytest.raises(VtoError, match="unknown"):
        spec.vector({"lip_gloss": 1.0})


def test_batched_normalise_shapes():
    spec = get_spec("hair", "hue,gamma,shine")
    raw = np.array([[1.0, 0.5, 0.2], [3.0, 0.0, 1.0]])
    unit = spec.normalise(raw)
    assert unit.shape == (2, 3) and unit.dtype == np.float32
    assert np.allclose(unit, [[0.2, 0.5, 0.2], [1.0, 0.0, 1.0]])
    with pytest.raises(VtoError, match="last axis of 3"):
        spec.normalise(np.zeros((2, 4)))


def test_json_round_trip_and_same_as():
    spec = get_spec("lipstick", "red,gloss")
    back = RendererSpec.from_dict(json.loads(spec.to_json()))
    assert back.same_as(spec) and back.by_name["gloss"].high == math.inf
    assert not back.same_as(get_spec("lipstick", "red,green"))
    with pytest.raises(VtoError, match="not a renderer spec"):
        RendererSpec.from_dict({"renderer": "hair"})


def test_vto_spec_names_what_is_left_out_below_the_visibility_bar(capsys):
    from vto_core import cli

    assert cli.run(["spec", "lipstick"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "sparkle_size" in out["left_out"] and "3x above render noise" in out["left_out"]["sparkle_size"]
    assert "2.36x" in out["left_out"]["gloss_roughness"] and "below_visibility_bar" not in out
    assert cli.run(["spec", "hair", "--params", "hue,shine"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["left_out"]["gamma"] == "not selected"
