"""The encoder's session (vto_core.inference): views of one product read as one estimate, their mean."""

from pathlib import Path

import numpy as np

from vto_core.inference import EncoderSession, mean_unit
from vto_core.products import get_spec

MODELS = Path(__file__).resolve().parents[2] / "blender_addon" / "models"


def test_the_mean_of_views_is_taken_in_the_unit_range_and_on_the_circle_for_a_hue():
    spec = get_spec("hair")
    hue = spec.modelled.index("hue")
    unit = np.full((2, len(spec.modelled)), 0.2)
    unit[:, hue] = (0.95, 0.05)  # either side of red
    unit[1, 0] = 0.6
    mean = mean_unit(spec, unit)
    assert abs(mean[0] - 0.4) < 1e-9 and min(mean[hue], 1 - mean[hue]) < 1e-9  # red, not cyan (0.5)
    assert np.array_equal(mean_unit(spec, unit[:1]), unit[0])  # one view: itself, bit for bit


def test_predict_views_reads_each_group_as_the_mean_of_its_views():
    session = EncoderSession(MODELS / "eyeshadow_encoder.onnx")
    rng = np.random.default_rng(0)
    views = [rng.random((64, 64, 3)).astype(np.float32) for _ in range(3)]
    one, pair = session.predict_views([[views[0]], views[1:]])
    assert one == session.predict(views[0])[0]
    spec = session.spec
    units = np.clip(session.predict_unit_nchw(np.stack([session.prepare(v) for v in views[1:]])), 0, 1)
    expected = spec.values(spec.denormalise(units.mean(axis=0)))
    assert all(abs(pair[name] - expected[name]) < 1e-5 * (p.high - p.low) for name, p in zip(spec.modelled,
                                                                                         spec.modelled_params))
    assert any(abs(pair[name] - one[name]) > 1e-3 for name in spec.modelled)
