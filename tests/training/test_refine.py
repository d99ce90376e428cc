"""Gradient refinement through a tiny imitator: exact steps, inside the ranges, never worse, refusals."""

import numpy as np
import pytest

pytestmark = [pytest.mark.torch, pytest.mark.blender]
torch = pytest.importorskip("torch")
pytest.importorskip("bpy")

from training.config import ImitatorConfig, resolve_config  # noqa: E402
from training.refine import ImitatorRefiner  # noqa: E402
from training.train_imitator import train_imitator  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.products import get_spec  # noqa: E402

SPEC = get_spec("lipstick", "opacity,red,green,blue")


@pytest.fixture(scope="module")
def imitator_run(lipstick_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("refine") / "imitator"
    train_imitator(str(lipstick_dataset), str(out), resolve_config(ImitatorConfig, None, [
        "width=8", "n_down=1", "n_res=1", "critic_width=8", "critic_layers=2", "batch_size=8", "perceptual=ssim_l1",
        "lr=0.003", "use_gan=false", "steps=40", "log_every=20"]))
    return out


@pytest.fixture(scope="module")
def sample(lipstick_dataset):
    return DatasetReader(lipstick_dataset)[0]


@pytest.mark.parametrize("distance", ["perceptual", "l1"])
def test_refinement_takes_k_steps_stays_in_range_and_improves_from_a_wrong_start(distance, imitator_run, sample):
    refiner = ImitatorRefiner(str(imitator_run), SPEC, distance)
    assert refiner.image_size == (16, 16) and refiner.distance_name == ("ssim_l1" if distance == "perceptual" else "l1")
    start = 1.0 - np.round(sample.unit)  # every parameter at the range end away from the truth
    found = refiner.refine(sample.source, sample.render, start, 8)
    assert found.steps == 8 and found.unit.shape == (SPEC.size,)
    assert ((0 <= found.unit) & (found.unit <= 1)).all()
    assert found.start_loss == pytest.approx(refiner.objective(sample.source, sample.render, start), rel=1e-5)
    assert found.loss == pytest.approx(refiner.objective(sample.source, sample.render, found.unit), rel=1e-5)
    assert found.loss < found.start_loss  # its own objective, through the imitator


@pytest.mark.parametrize("start", [np.zeros(4), np.ones(4), np.array([-0.5, 1.5, 2.0, -3.0])])
def test_starts_at_and_beyond_the_range_ends_give_finite_results_inside_them(start, imitator_run, sample):
    found = ImitatorRefiner(str(imitator_run), SPEC).refine(sample.source, sample.render, start, 3)
    assert np.isfinite(found.unit).all() and ((0 <= found.unit) & (found.unit <= 1)).all()
    assert np.isfinite([found.loss, found.start_loss]).all() and found.loss <= found.start_loss


def test_wrapping_parameters_wrap_instead_of_clamping(imitator_run):
    refiner = ImitatorRefiner(str(imitator_run), SPEC)
    refiner.wraps = torch.tensor([True, False, False, False])  # as for hue
    boxed = refiner._into_box(torch.tensor([[1.25, 1.25, -0.5, 0.5]]))
    assert boxed[0].tolist() == pytest.approx([0.25, 1.0, 0.0, 0.5])


def test_refusals_are_one_line(imitator_run, sample, tmp_path):
    with pytest.raises(VtoError, match="another parameter spec"):
        ImitatorRefiner(str(imitator_run), get_spec("lipstick", "red"))
    with pytest.raises(VtoError, match="imitates the lipstick renderer, not hair"):
        ImitatorRefiner(str(imitator_run), get_spec("hair"))
    with pytest.raises(VtoError, match="no imitator run folder"):
        ImitatorRefiner(str(tmp_path / "none"), SPEC)
    assert not (tmp_path / "none").exists()
    with pytest.raises(VtoError, match="unknown refinement distance"):
        ImitatorRefiner(str(imitator_run), SPEC, "l2")
    refiner = ImitatorRefiner(str(imitator_run), SPEC)
    with pytest.raises(VtoError, match="the imitator works on 16x16"):
        refiner.refine(np.zeros((32, 32, 3)), np.zeros((32, 32, 3)), np.full(4, 0.5), 2)
    with pytest.raises(VtoError, match="at least 1 step"):
        refiner.refine(sample.source, sample.render, np.full(4, 0.5), 0)
    with pytest.raises(VtoError, match="the start has 3 values"):
        refiner.refine(sample.source, sample.render, np.full(3, 0.5), 2)
