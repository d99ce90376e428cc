"""Tests for training.losses: sensitivity, graphics, WGAN-GP, SSIM and perceptual distance."""

import math
import warnings

import pytest

pytestmark = pytest.mark.torch
torch = pytest.importorskip("torch")

from training.losses import (  # noqa: E402
    PerceptualDistance,
    critic_loss,
    generator_adversarial_loss,
    gradient_penalty,
    graphics_loss,
    graphics_errors,
    parameter_weights,
    parameter_difference,
    sensitivity_loss,
    ssim,
    weighted_total,
)
from vto_core.errors import VtoError  # noqa: E402
from vto_core.metrics import ssim as numpy_ssim  # noqa: E402

# Conv layer indices of torchvision's vgg16().features and their (out, in) channels.
_VGG16_CONVS = [
    (0, 64, 3), (2, 64, 64), (5, 128, 64), (7, 128, 128), (10, 256, 128), (12, 256, 256),
    (14, 256, 256), (17, 512, 256), (19, 512, 512), (21, 512, 512), (24, 512, 512),
    (26, 512, 512), (28, 512, 512),
]  # fmt: skip


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """Tiny tensors: one thread avoids thread-pool contention on busy machines."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


def _images(batch, size, channels=3, seed=0, dtype=torch.float32):
    """Reproducible random images (batch, channels, size, size) in [0, 1]."""
    generator = torch.Generator().manual_seed(seed)
    return torch.rand(batch, channels, size, size, generator=generator, dtype=dtype)


class _LinearCritic(torch.nn.Module):
    """D(x) = sum(w * x) per sample, whose input gradient is w everywhere."""

    def __init__(self, weight):
        super().__init__()
        self.weight = torch.nn.Parameter(weight)

    def forward(self, x):
        return (self.weight * x).flatten(1).sum(1)


class _MeanCritic(torch.nn.Module):
    """D(x) = scale * mean(x) per sample."""

    def __init__(self, scale=1.0):
        super().__init__()
        self.scale = scale

    def forward(self, x):
        return self.scale * x.flatten(1).mean(1)


# --- sensitivity_loss ---------------------------------------------------------------------------


def test_sensitivity_loss_is_zero_when_differences_match():
    real_base = _images(2, 4, seed=1)
    real_moved = torch.rand(2, 3, 3, 4, 4, generator=torch.Generator().manual_seed(2))
    offset = 0.25
    loss = sensitivity_loss(real_base, real_moved, real_base + offset, real_moved + offset)
    assert loss.item() == pytest.approx(0.0, abs=1e-12)


def test_sensitivity_loss_is_positive_when_differences_differ():
    real_base = _images(2, 4, seed=1)
    real_moved = torch.rand(2, 3, 3, 4, 4, generator=torch.Generator().manual_seed(2))
    # The imitator ignores the parameter change entirely.
    fake_moved = real_base.unsqueeze(1).expand(-1, 3, -1, -1, -1)
    assert sensitivity_loss(real_base, real_moved, real_base, fake_moved).item() > 1e-3


def test_sensitivity_loss_hand_computed_tiny_case():
    # B=1, m=2, one-pixel one-channel images.
    real_base = torch.tensor([[[[1.0]]]])
    real_moved = torch.tensor([[[[[0.5]]], [[[2.0]]]]])  # renderer changes: 0.5, -1.0
    fake_base = torch.tensor([[[[0.0]]]])
    fake_moved = torch.tensor([[[[[0.0]]], [[[0.5]]]]])  # imitator changes: 0.0, -0.5
    loss = sensitivity_loss(real_base, real_moved, fake_base, fake_moved)
    assert loss.item() == pytest.approx((0.5 - 0.0) ** 2 + (-1.0 + 0.5) ** 2)


def test_sensitivity_loss_means_over_pixels_sums_over_parameters_means_over_batch():
    real_base = torch.zeros(2, 1, 2, 2)
    real_moved = torch.zeros(2, 3, 1, 2, 2)
    fake_base = torch.zeros(2, 1, 2, 2)
    fake_moved = torch.zeros(2, 3, 1, 2, 2)
    fake_moved[0, :, 0, 0, 0] = 2.0  # sample 0: each parameter errs by 2 on one of 4 pixels
    loss = sensitivity_loss(real_base, real_moved, fake_base, fake_moved)
    # Per parameter 4/4 = 1; summed over 3 parameters = 3; sample 1 is 0; batch mean = 1.5.
    assert loss.item() == pytest.approx(1.5)


def test_sensitivity_loss_refuses_mismatched_shapes():
    base = torch.zeros(2, 3, 4, 4)
    moved = torch.zeros(2, 5, 3, 4, 4)
    with pytest.raises(VtoError, match="real_moved"):
        sensitivity_loss(base, torch.zeros(2, 5, 3, 4, 5), base, moved)
    with pytest.raises(VtoError, match="base renders"):
        sensitivity_loss(base, moved, torch.zeros(1, 3, 4, 4), moved)
    with pytest.raises(VtoError, match="differ"):
        sensitivity_loss(base, moved, base, torch.zeros(2, 4, 3, 4, 4))


# --- graphics_loss ------------------------------------------------------------------------------


def test_graphics_loss_hand_computed():
    g_true = torch.tensor([[0.0, 1.0], [0.5, 0.5]])
    g_pred = torch.tensor([[1.0, 1.0], [0.0, 1.5]])
    # Sample 0: 1 + 0 = 1; sample 1: 0.25 + 1 = 1.25; mean 1.125.
    assert graphics_loss(g_true, g_pred).item() == pytest.approx(1.125)


def test_graphics_loss_absolute_and_weighted_hand_computed():
    g_true = torch.tensor([[0.0, 1.0], [0.5, 0.5]])
    g_pred = torch.tensor([[1.0, 1.0], [0.0, 1.5]])
    # Absolute: sample 0: 1 + 0; sample 1: 0.5 + 1; mean 1.25.
    assert graphics_loss(g_true, g_pred, error="absolute").item() == pytest.approx(1.25)
    # Squared, weights (2, 0.5): sample 0: 2 x 1; sample 1: 2 x 0.25 + 0.5 x 1; mean 1.5.
    assert graphics_loss(g_true, g_pred, weights=[2.0, 0.5]).item() == pytest.approx(1.5)
    # A wrapping dimension stays on the circle: 0.95 -> 0.05 is 0.1 away.
    assert graphics_loss(torch.tensor([[0.95]]), torch.tensor([[0.05]]), [True], "absolute").item() == (
        pytest.approx(0.1))


def test_graphics_loss_refuses_mismatched_shapes_and_unknown_errors():
    with pytest.raises(VtoError, match="graphics_loss"):
        graphics_loss(torch.zeros(2, 3), torch.zeros(2, 4))
    with pytest.raises(VtoError, match="error must be squared or absolute, got 'cubed'"):
        graphics_loss(torch.zeros(2, 3), torch.zeros(2, 3), error="cubed")


def test_graphics_loss_takes_the_absolute_error_of_the_parameters_named_and_squares_the_rest():
    g_true = torch.tensor([[0.0, 1.0], [0.5, 0.5]])
    g_pred = torch.tensor([[1.0, 1.0], [0.0, 1.5]])
    error = graphics_errors("squared", "green", ["red", "green"])
    assert error == [False, True]
    # Red squared, green absolute: sample 0: 1 + 0; sample 1: 0.25 + 1; mean 1.125. Absolute red: |0.5| -> 1.25.
    assert graphics_loss(g_true, g_pred, error=error).item() == pytest.approx(1.125)
    assert graphics_loss(g_true, g_pred, error=[True, False]).item() == pytest.approx(1.25)
    assert graphics_errors("absolute", "green", ["red", "green"]) == [True, True]
    assert graphics_errors("squared", " ", ["red", "green"]) == "squared"


def test_graphics_errors_refuse_a_parameter_not_modelled_and_a_list_of_the_wrong_length():
    with pytest.raises(VtoError, match="absolute_parameters: rouge not among red, green"):
        graphics_errors("squared", "red,rouge", ["red", "green"])
    with pytest.raises(VtoError, match="3 per-parameter errors for 2 parameters"):
        graphics_loss(torch.zeros(2, 2), torch.zeros(2, 2), error=[True, False, True])


def test_parameter_weights_name_some_parameters_and_leave_the_rest_at_one():
    names = ["opacity", "red", "green", "blue"]
    assert parameter_weights("", names) is None
    assert parameter_weights("red=4, blue=0.5", names) == [1.0, 4.0, 1.0, 0.5]


@pytest.mark.parametrize("setting", ["red", "rouge=2", "red=-1", "red=x", "red=inf", "red=4,"])
def test_parameter_weights_refuse_what_is_not_a_weight_for_a_parameter(setting):
    with pytest.raises(VtoError, match="is not name=weight with a weight of at least 0 for one of opacity, red"):
        parameter_weights(setting, ["opacity", "red"])


# --- WGAN-GP ------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gradient_penalty_of_a_linear_critic_is_exact_for_any_mix(seed):
    torch.manual_seed(seed)
    weight = torch.randn(1, 3, 4, 4, dtype=torch.float64)
    critic = _LinearCritic(weight.clone())
    real = _images(3, 4, dtype=torch.float64, seed=seed)
    fake = _images(3, 4, dtype=torch.float64, seed=seed + 10)
    penalty = gradient_penalty(critic, real, fake)
    expected = (weight.norm().item() - 1.0) ** 2
    assert penalty.item() == pytest.approx(expected, rel=1e-12)

    penalty.backward()
    norm = weight.norm()
    expected_grad = 2 * (norm - 1) * weight / norm
    assert torch.isfinite(critic.weight.grad).all()
    assert torch.allclose(critic.weight.grad, expected_grad, rtol=1e-10)


def test_gradient_penalty_is_zero_for_a_unit_gradient_critic():
    weight = torch.zeros(1, 1, 2, 2)
    weight[0, 0, 0, 0] = 1.0
    penalty = gradient_penalty(_LinearCritic(weight), torch.rand(2, 1, 2, 2), torch.rand(2, 1, 2, 2))
    assert penalty.item() == pytest.approx(0.0, abs=1e-12)


def test_critic_loss_is_fake_minus_real_plus_weighted_penalty():
    critic = _MeanCritic(scale=2.0)
    real = torch.full((2, 1, 2, 2), 0.75)
    fake = torch.full((2, 1, 2, 2), 0.25)
    # Gradient of 2 * mean over 4 pixels: 0.5 per pixel, norm 1 -> penalty 0.
    assert critic_loss(critic, real, fake).item() == pytest.approx(0.5 - 1.5)
    # A steeper critic: gradient norm 2 -> penalty 1, times lambda_gp.
    steep = _MeanCritic(scale=4.0)
    assert critic_loss(steep, real, fake, lambda_gp=3.0).item() == pytest.approx(1.0 - 3.0 + 3.0)


def test_critic_loss_does_not_send_gradients_to_the_generator():
    critic = _LinearCritic(torch.randn(1, 1, 2, 2))
    fake = torch.rand(2, 1, 2, 2, requires_grad=True)
    critic_loss(critic, torch.rand(2, 1, 2, 2), fake).backward()
    assert fake.grad is None
    assert critic.weight.grad is not None and critic.weight.grad.abs().sum() > 0


def test_generator_loss_falls_as_the_critic_rates_fakes_higher():
    critic = _MeanCritic()
    low = generator_adversarial_loss(critic, torch.full((2, 1, 2, 2), 0.2))
    high = generator_adversarial_loss(critic, torch.full((2, 1, 2, 2), 0.9))
    assert low.item() == pytest.approx(-0.2)
    assert high.item() == pytest.approx(-0.9)
    assert high < low


# --- SSIM ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize(("height", "width"), [(16, 16), (24, 24), (8, 10), (5, 7)])
def test_ssim_matches_the_numpy_metric(dtype, height, width):
    generator = torch.Generator().manual_seed(height * width)
    x = torch.rand(3, 3, height, width, generator=generator, dtype=dtype)
    # Correlated pairs give SSIM values away from 0, where agreement matters most.
    y = (0.7 * x + 0.3 * torch.rand(3, 3, height, width, generator=generator, dtype=dtype)).clamp(0, 1)
    values = ssim(x, y)
    assert values.shape == (3,)
    for index in range(3):
        expected = numpy_ssim(x[index].permute(1, 2, 0).double().numpy(), y[index].permute(1, 2, 0).double().numpy())
        assert values[index].item() == pytest.approx(expected, abs=1e-5)


def test_ssim_of_an_image_with_itself_is_one():
    x = _images(2, 16)
    assert torch.allclose(ssim(x, x), torch.ones(2), atol=1e-6)


def test_ssim_is_differentiable():
    x = _images(1, 16).requires_grad_(True)
    y = _images(1, 16, seed=3)
    (1 - ssim(x, y)).sum().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all() and x.grad.abs().sum() > 0


def test_ssim_refuses_images_under_three_pixels():
    with pytest.raises(VtoError, match="smaller than"):
        ssim(torch.rand(1, 3, 2, 8), torch.rand(1, 3, 2, 8))


# --- PerceptualDistance -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def vgg_weights_file(tmp_path_factory):
    """A random-weight state dict in torchvision's vgg16 format, saved to a temporary file."""
    generator = torch.Generator().manual_seed(0)
    state = {}
    for index, out_channels, in_channels in _VGG16_CONVS:
        scale = math.sqrt(2.0 / (in_channels * 9))
        state[f"features.{index}.weight"] = scale * torch.randn(
            out_channels, in_channels, 3, 3, generator=generator
        )
        state[f"features.{index}.bias"] = 0.01 * torch.randn(out_channels, generator=generator)
    state["classifier.0.weight"] = torch.zeros(4, 4)
    path = tmp_path_factory.mktemp("vgg") / "vgg16-random.pth"
    torch.save(state, path)
    return path


@pytest.fixture
def no_default_weights(tmp_path, monkeypatch):
    """Point TORCH_HOME at an empty folder and drop VTO_VGG16_WEIGHTS."""
    monkeypatch.setenv("TORCH_HOME", str(tmp_path / "torch-home"))
    monkeypatch.delenv("VTO_VGG16_WEIGHTS", raising=False)
    return tmp_path / "torch-home"


def test_vgg_mode_loads_torchvision_weights(vgg_weights_file, no_default_weights):
    distance = PerceptualDistance(mode="vgg", weights_path=vgg_weights_file)
    assert distance.kind == "vgg"
    assert distance.weights_path == vgg_weights_file
    assert torch.equal(distance.features[28].bias, torch.load(vgg_weights_file)["features.28.bias"])
    assert not distance.training
    assert not any(parameter.requires_grad for parameter in distance.parameters())

    x = _images(2, 16, seed=4)
    y = _images(2, 16, seed=5)
    assert distance(x, x).item() == 0.0
    assert distance(x, y).item() > 0.0
    assert distance(x, y).ndim == 0

    x.requires_grad_(True)
    distance(x, y).backward()
    assert x.grad is not None and x.grad.abs().sum() > 0


def test_vgg_distance_sums_relu1_2_relu2_2_relu3_3_feature_mses(vgg_weights_file, no_default_weights):
    distance = PerceptualDistance(mode="vgg", weights_path=vgg_weights_file)
    x = _images(1, 16, seed=6)
    y = _images(1, 16, seed=7)
    mean = torch.tensor([0.485, 0.456, 0.406]).view(1, 3, 1, 1)
    std = torch.tensor([0.229, 0.224, 0.225]).view(1, 3, 1, 1)
    features_x, features_y = (x - mean) / std, (y - mean) / std
    expected = 0.0
    for index in range(16):
        features_x = distance.features[index](features_x)
        features_y = distance.features[index](features_y)
        if index in (3, 8, 15):
            expected += (features_x - features_y).pow(2).mean().item()
    assert distance(x, y).item() == pytest.approx(expected, rel=1e-5)


def test_vgg_weights_come_from_the_environment_variable(vgg_weights_file, no_default_weights, monkeypatch):
    monkeypatch.setenv("VTO_VGG16_WEIGHTS", str(vgg_weights_file))
    distance = PerceptualDistance()
    assert distance.kind == "vgg"
    assert distance.weights_path == vgg_weights_file


def test_vgg_weights_come_from_the_torch_hub_cache(vgg_weights_file, no_default_weights):
    checkpoints = no_default_weights / "hub" / "checkpoints"
    checkpoints.mkdir(parents=True)
    (checkpoints / "vgg16-397923af.pth").symlink_to(vgg_weights_file)
    distance = PerceptualDistance(mode="vgg")
    assert distance.weights_path == checkpoints / "vgg16-397923af.pth"


def test_auto_mode_without_weights_warns_and_uses_ssim_l1(no_default_weights):
    with pytest.warns(UserWarning, match="falls back to SSIM\\+L1") as caught:
        distance = PerceptualDistance(mode="auto")
    assert str(no_default_weights / "hub" / "checkpoints" / "vgg16-397923af.pth") in str(caught[0].message)
    assert distance.kind == "ssim_l1"
    assert distance.weights_path is None
    x = _images(2, 16, seed=8)
    y = _images(2, 16, seed=9)
    expected = (1 - ssim(x, y)).mean() + (x - y).abs().mean()
    assert distance(x, y).item() == pytest.approx(expected.item())
    assert distance(x, x).item() == pytest.approx(0.0, abs=1e-6)


def test_ssim_l1_mode_is_quiet_and_differentiable(no_default_weights):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        distance = PerceptualDistance(mode="ssim_l1")
    x = _images(1, 16, seed=10).requires_grad_(True)
    y = _images(1, 16, seed=11).requires_grad_(True)
    distance(x, y).backward()
    assert x.grad.abs().sum() > 0 and y.grad.abs().sum() > 0


def test_vgg_mode_without_weights_raises_naming_where_it_looked(no_default_weights):
    with pytest.raises(VtoError, match="no VGG16 weights found") as caught:
        PerceptualDistance(mode="vgg")
    assert str(no_default_weights) in str(caught.value)


def test_missing_explicit_weights_file_raises(tmp_path):
    with pytest.raises(VtoError, match="does not exist"):
        PerceptualDistance(mode="auto", weights_path=tmp_path / "missing.pth")


def test_a_file_that_is_not_vgg16_raises(tmp_path):
    path = tmp_path / "other.pth"
    torch.save({"features.0.weight": torch.zeros(2, 2)}, path)
    with pytest.raises(VtoError, match="not a torchvision VGG16 state dict"):
        PerceptualDistance(mode="vgg", weights_path=path)


def test_unknown_mode_raises():
    with pytest.raises(VtoError, match="unknown mode 'lpips'"):
        PerceptualDistance(mode="lpips")


def test_graphics_loss_takes_hue_on_the_circle():
    truth, guess = torch.tensor([[0.98, 0.5]]), torch.tensor([[0.02, 0.5]])
    assert float(graphics_loss(truth, guess, wraps=[True, False])) == pytest.approx(0.04 ** 2, abs=1e-6)
    assert float(graphics_loss(truth, guess)) == pytest.approx(0.96 ** 2, abs=1e-6)  # a linear dimension
    guess.requires_grad_(True)
    graphics_loss(truth, guess, wraps=[True, False]).backward()
    assert guess.grad[0, 0] > 0  # pushes 0.02 down towards 0.98 across the wrap, not up across the range


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize(("height", "width", "noise"), [(20, 26, 0.1), (11, 11, 0.05), (64, 64, 0.3), (32, 17, 0.02)])
def test_torch_ssim_equals_scikit_image(dtype, height, width, noise):
    """scikit-image 0.26 structural_similarity (Wang et al. settings) per image of a batch."""
    import numpy as np
    from skimage.metrics import structural_similarity

    rng = np.random.default_rng(height * width)
    a = rng.random((2, height, width, 3))
    b = np.clip(a + rng.normal(0, noise, a.shape), 0, 1)
    as_tensor = lambda x: torch.from_numpy(x.transpose(0, 3, 1, 2).copy()).to(dtype)  # noqa: E731
    got = ssim(as_tensor(a), as_tensor(b))
    for index in range(2):
        expected = structural_similarity(a[index], b[index], gaussian_weights=True, sigma=1.5,
                                         use_sample_covariance=False, data_range=1.0, channel_axis=-1)
        assert float(got[index]) == pytest.approx(expected, abs=1e-5 if dtype == torch.float32 else 1e-10)


# --- weighted terms, validation error on the circle --------------------------------------------------------------


def test_weighted_total_logs_each_term_both_ways():
    imitation, sensitivity = torch.tensor(0.5, requires_grad=True), torch.tensor(0.004, requires_grad=True)
    losses, total = weighted_total({"imitation": (imitation, 100.0), "sensitivity": (sensitivity, 1000.0)})
    assert {k: round(float(v), 6) for k, v in losses.items()} == {
        "imitation": 0.5, "imitation_weighted": 50.0, "sensitivity": 0.004, "sensitivity_weighted": 4.0, "total": 54.0}
    total.backward()
    assert (float(imitation.grad), float(sensitivity.grad)) == (100.0, 1000.0)
    assert not any(value.requires_grad for value in losses.values())


def test_wrapping_dimensions_come_from_the_spec():
    from vto_core.products import get_spec

    spec = get_spec("hair")
    wraps = [p.wraps for p in spec.modelled_params]
    assert [name for name, w in zip(spec.modelled, wraps) if w] == ["hue"]
    truth = torch.full((1, spec.size), 0.5)
    guess = truth.clone()
    hue = spec.modelled.index("hue")
    truth[0, hue], guess[0, hue] = 0.98, 0.02
    assert float(graphics_loss(truth, guess, wraps)) == pytest.approx(0.04**2, abs=1e-6)
    assert float(parameter_difference(truth, guess, wraps)[0, hue]) == pytest.approx(0.04, abs=1e-6)
    assert float(parameter_difference(guess, truth, wraps)[0, hue]) == pytest.approx(-0.04, abs=1e-6)
    # an encoder's linear output may leave [0, 1]: 1.02 is 0.02 on the circle
    assert float(parameter_difference(torch.tensor([[0.0]]), torch.tensor([[1.02]]), [True])[0, 0]) == \
        pytest.approx(0.02, abs=1e-6)


def test_validation_error_takes_hue_on_the_circle():
    from training.train_encoder import parameter_error

    class Says(torch.nn.Module):
        """An 'encoder' that answers 0.02 for every parameter."""

        def forward(self, images):
            return torch.full((len(images), 2), 0.02)

    batches = [{"g": torch.tensor([[0.98, 0.98]]), "render": torch.zeros(1, 3, 8, 8)}]
    assert parameter_error(Says(), batches, "cpu", [True, False]) == pytest.approx((0.04**2 + 0.96**2) / 2, abs=1e-6)
    assert parameter_error(Says(), batches, "cpu") == pytest.approx(0.96**2, abs=1e-6)


def test_the_colour_loss_reads_the_shipped_colour_imitator_as_onnxruntime_does():
    """training.export.onnx_colour_net: the same statistics as the ONNX file; the loss is 0 at the truth, grows away
    from it, and sends gradients to the estimate only."""
    from pathlib import Path

    import numpy as np

    from training.export import onnx_colour_net
    from training.losses import colour_loss
    from vto_core.colour_imitator import ColourImitator

    path = Path(__file__).resolve().parents[2] / "blender_addon" / "models" / "lipstick_colour.onnx"
    imitator = ColourImitator(path)
    net = onnx_colour_net(str(path), imitator.spec)
    unit = np.random.default_rng(3).uniform(size=(5, imitator.spec.size)).astype(np.float32)
    assert np.abs(net(torch.from_numpy(unit)).numpy() - imitator.statistics(unit)).max() < 1e-3
    truth = torch.from_numpy(unit)
    guess = (truth + 0.2).clamp(0, 1).requires_grad_(True)
    assert float(colour_loss(net, truth, truth)) == 0.0
    loss = colour_loss(net, truth, guess)
    loss.backward()
    assert float(loss) > 0.01 and torch.isfinite(guess.grad).all() and guess.grad.abs().sum() > 0
    assert not any(p.requires_grad for p in net.parameters())
