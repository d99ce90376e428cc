"""The colour imitator's session and its fit (vto_core.colour_imitator), on a hand-made linear imitator."""

import json

import numpy as np
import pytest

from vto_core.colour_imitator import INPUT_NAME, KIND, OUTPUT_NAME, ColourImitator, cached_imitator
from vto_core.errors import VtoError
from vto_core.products import get_spec

SPEC = get_spec("hair", "brightness,hue,saturation")
WEIGHTS = np.array([[40.0, 0.0, 5.0, 1.0], [0.0, 30.0, 0.0, -2.0], [3.0, 0.0, 25.0, 0.5]], np.float32)  # (m, F)
BIAS = np.array([10.0, -5.0, 2.0, 0.0], np.float32)


def linear_imitator(path, kind=KIND, spec=SPEC) -> str:
    """statistics = unit @ WEIGHTS + BIAS, as ONNX with the metadata an exported imitator carries."""
    import onnx
    from onnx import TensorProto, helper

    nodes = [helper.make_node("MatMul", [INPUT_NAME, "w"], ["product"]),
             helper.make_node("Add", ["product", "b"], [OUTPUT_NAME])]
    inits = [helper.make_tensor("w", TensorProto.FLOAT, WEIGHTS.shape, WEIGHTS.ravel()),
             helper.make_tensor("b", TensorProto.FLOAT, BIAS.shape, BIAS)]
    graph = helper.make_graph(nodes, "linear", [helper.make_tensor_value_info(INPUT_NAME, TensorProto.FLOAT,
                                                                              ["N", 3])],
                              [helper.make_tensor_value_info(OUTPUT_NAME, TensorProto.FLOAT, ["N", 4])], inits)
    model = helper.make_model(graph, ir_version=10, opset_imports=[helper.make_opsetid("", 18)])
    for key, value in {"vto.kind": kind, "vto.spec": json.dumps(spec.to_dict())}.items():
        model.metadata_props.add(key=key, value=value)
    onnx.save(model, str(path))
    return str(path)


@pytest.fixture
def imitator(tmp_path):
    return ColourImitator(linear_imitator(tmp_path / "linear.onnx"))


def test_statistics_are_the_networks_output_for_one_or_many_vectors(imitator):
    units = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.25]])
    np.testing.assert_allclose(imitator.statistics(units), units @ WEIGHTS + BIAS, rtol=1e-6)
    np.testing.assert_allclose(imitator.statistics(units[1]), units[1] @ WEIGHTS + BIAS, rtol=1e-6)
    assert imitator.spec.same_as(SPEC) and imitator.typical_skin is None  # not skin-conditioned


def test_the_fit_finds_the_parameters_that_show_the_target(imitator):
    truth = np.array([0.7, 0.3, 0.6])
    found = imitator.fit(truth @ WEIGHTS + BIAS, np.full(3, 0.5), 0.0, np.zeros(3, bool))
    np.testing.assert_allclose(found, truth, atol=1e-3)


def test_the_prior_holds_what_the_target_cannot_move_and_held_values_stay(imitator):
    start = np.array([0.5, 0.5, 0.5])
    target = np.array([0.9, 0.5, 0.5]) @ WEIGHTS + BIAS
    pulled = imitator.fit(target, start, 200.0, np.zeros(3, bool))
    assert np.abs(pulled - start).max() < 0.1  # a strong prior: the start stands
    held = imitator.fit(target, start, 0.0, np.zeros(3, bool), held={0: 0.2})
    assert held[0] == 0.2


def test_the_fit_stays_in_the_box_and_wraps_hue(imitator):
    far = np.array([3.0, 2.0, -1.0]) @ WEIGHTS + BIAS  # out of reach
    found = imitator.fit(far, np.full(3, 0.5), 0.0, np.array([False, True, False]))
    assert found[0] == 1.0 and found[2] == 0.0 and 0.0 <= found[1] < 1.0
    with pytest.raises(VtoError, match="finite target"):
        imitator.fit(np.full(4, np.inf), np.full(3, 0.5), 1.0, np.zeros(3, bool))


def test_bad_files_are_one_line_errors(tmp_path):
    with pytest.raises(VtoError, match="no colour imitator"):
        ColourImitator(tmp_path / "none.onnx")
    (tmp_path / "junk.onnx").write_bytes(b"junk")
    with pytest.raises(VtoError, match="cannot load"):
        ColourImitator(tmp_path / "junk.onnx")
    with pytest.raises(VtoError, match="not a VTO colour imitator"):
        ColourImitator(linear_imitator(tmp_path / "encoder.onnx", kind="encoder"))
    path = linear_imitator(tmp_path / "cached.onnx")
    assert cached_imitator(path) is cached_imitator(path)


def test_a_skin_conditioned_imitator_reads_the_skin_or_a_typical_one(tmp_path):
    """Lips: the network also takes the skin's CIELAB / 100 after the parameters."""
    import onnx
    from onnx import TensorProto, helper

    weights = np.zeros((5, 1), np.float32)  # 2 parameters, then the skin's L*, a*, b* / 100
    weights[4, 0] = 100.0  # statistic = the skin's b*, whatever the parameters
    graph = helper.make_graph([helper.make_node("MatMul", [INPUT_NAME, "w"], [OUTPUT_NAME])], "skin",
                              [helper.make_tensor_value_info(INPUT_NAME, TensorProto.FLOAT, ["N", 5])],
                              [helper.make_tensor_value_info(OUTPUT_NAME, TensorProto.FLOAT, ["N", 1])],
                              [helper.make_tensor("w", TensorProto.FLOAT, weights.shape, weights.ravel())])
    model = helper.make_model(graph, ir_version=10, opset_imports=[helper.make_opsetid("", 18)])
    for key, value in {"vto.kind": KIND, "vto.spec": json.dumps(get_spec("hair", "hue,shine").to_dict()),
                       "vto.typical_skin_lab": "[60.0, 15.0, 20.0]"}.items():
        model.metadata_props.add(key=key, value=value)
    onnx.save(model, str(tmp_path / "skin.onnx"))
    imitator = ColourImitator(tmp_path / "skin.onnx")
    assert imitator.statistics(np.array([0.2, 0.4]))[0] == pytest.approx(20.0, abs=1e-4)  # the typical skin
    assert imitator.statistics(np.array([0.2, 0.4]), np.array([40.0, 10.0, 30.0]))[0] == pytest.approx(30.0,
                                                                                                       abs=1e-4)


def test_starts_side_by_side_fit_as_each_alone(imitator):
    target = np.array([0.9, 0.2, 0.4]) @ WEIGHTS + BIAS
    starts = np.array([[0.5, 0.5, 0.5], [0.1, 0.9, 0.2], [0.8, 0.1, 0.9]])
    wraps = np.array([False, True, False])
    together = imitator.fit(target, starts, 2.0, wraps, held={2: 0.3})
    alone = np.stack([imitator.fit(target, start, 2.0, wraps, held={2: 0.3}) for start in starts])
    assert together.shape == (3, 3) and np.abs(together - alone).max() < 1e-6
    assert (together[:, 2] == 0.3).all()
