"""The compositor hair stage agrees with its numpy reference (vto_core.hair), extremes included."""

import numpy as np
import pytest

pytestmark = pytest.mark.blender
pytest.importorskip("bpy")

from blender_addon.hair import load_swatch, render_hair_source, run_hair_stage  # noqa: E402
from vto_core.hair import render_hair_reference  # noqa: E402
from vto_core.specs import get_spec  # noqa: E402

SPEC = get_spec("hair")
CASES = [("defaults", {})] + [
    (f"{p.name}={value:g}", {p.name: value}) for p in SPEC.params for value in (p.low, p.high)
] + [("mixed", {"hue": 0.6, "saturation": 2.5, "shine": 0.5, "blend": 0.0, "intensity": 0.7, "gamma": 2.0})]


@pytest.fixture(scope="module")
def hair_source():
    return render_hair_source(3, 64, 16)


@pytest.mark.parametrize("name, values", CASES, ids=[c[0] for c in CASES])
def test_compositor_matches_numpy_reference(name, values, hair_source):
    swatch = load_swatch()
    full = SPEC.full_values(values)
    blender = run_hair_stage(hair_source, full, swatch)
    reference = render_hair_reference(hair_source.rgb, hair_source.mask, swatch, full)
    error = np.abs(blender - reference).max(axis=-1)[hair_source.mask > 0.5] * 255
    print(f"{name}: masked MAE {error.mean():.4f}/255, p99 {np.percentile(error, 99):.3f}/255, max {error.max():.2f}/255")
    assert error.mean() < 1.0
    assert error.max() < 0.5  # the reference folds the C curve into 257-point channel tables as Blender does
    outside = np.abs(blender - hair_source.rgb)[hair_source.mask < 0.5]
    assert outside.max() < 1e-4, "pixels outside the hair mask must not change"


def test_blend_changes_the_render_monotonically_over_its_whole_range(hair_source):
    hair = hair_source.mask > 0.5
    change = [np.abs(run_hair_stage(hair_source, {"blend": b, "hue": 0.5}) - hair_source.rgb)[hair].mean()
              for b in np.linspace(-1, 1, 9)]
    assert np.all(np.diff(change) < -1e-3), f"blend must colour less hair at every step: {np.round(change, 4)}"
    assert change[-1] == 0.0


def test_hue_wraps_in_the_compositor(hair_source):
    low = run_hair_stage(hair_source, {"hue": 0.001, "saturation": 2.0})
    high = run_hair_stage(hair_source, {"hue": 0.999, "saturation": 2.0})
    half = run_hair_stage(hair_source, {"hue": 0.5, "saturation": 2.0})
    # 0.002 turns apart: alike but for a few pixels where the matching LUT is steep
    assert np.abs(low - high).mean() < 0.5 / 255 and np.percentile(np.abs(low - high), 99) < 4 / 255
    assert np.abs(low - half).max() > 50 / 255
