"""The colour imitator learns what the default scene's region shows (training/train_colour.py), on real renders."""

import numpy as np
import pytest

pytestmark = [pytest.mark.torch, pytest.mark.blender, pytest.mark.slow]
pytest.importorskip("torch")
pytest.importorskip("bpy")

from training.config import ColourConfig, resolve_config  # noqa: E402
from training.train_colour import region_targets, train_colour  # noqa: E402
from vto_core.colour_imitator import ColourImitator  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402


@pytest.fixture(scope="module")
def hair_looks(tmp_path_factory):
    """96 looks of the hair stage on 6 default hair regions (16 px): the renders with their hair masks."""
    from blender_addon.datasets.commands import cmd_dataset

    out = tmp_path_factory.mktemp("colour") / "hair"
    assert cmd_dataset(["hair", "--out", str(out), "--n", "96", "--seed", "3", "--res", "16", "--samples", "2",
                        "--looks-per-source", "16", "--quiet"]) == 0
    return str(out)


def test_the_imitator_predicts_the_regions_statistics_far_better_than_their_mean(hair_looks, tmp_path):
    units, targets, spec = region_targets([hair_looks])
    assert units.shape == (96, 7) and targets.shape == (96, 11) and spec["renderer"] == "hair"
    config = resolve_config(ColourConfig, None, ["steps=600", "width=32", "val_fraction=0.2"])
    result = train_colour([hair_looks], str(tmp_path / "hair_colour.onnx"), config)
    imitator = ColourImitator(tmp_path / "hair_colour.onnx")
    predicted = imitator.statistics(units)
    fitted = np.abs(predicted - targets).mean()
    baseline = np.abs(targets - targets.mean(0)).mean()
    assert fitted < 0.5 * baseline, (fitted, baseline)
    assert result["max_abs_diff"] < 1e-3 and imitator.spec.to_dict() == spec and imitator.typical_skin is None
    assert len(result["held_out_mean_abs_error"]) == 11


def test_a_lipstick_dataset_without_masks_is_one_line(lipstick_dataset, tmp_path):
    with pytest.raises(VtoError, match="--masks"):
        region_targets([str(lipstick_dataset)])
    with pytest.raises(VtoError, match="does not exist"):
        train_colour([str(lipstick_dataset)], str(tmp_path / "none" / "x.onnx"), ColourConfig())
