"""Training losses: rendering sensitivity, graphics, WGAN-GP, SSIM and perceptual distance."""

import math
import os
import warnings
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from vto_core.errors import VtoError

# Same constants as vto_core.metrics.ssim, so the two agree.
_SSIM_WINDOW_SIZE = 11
_SSIM_MIN_WINDOW_SIZE = 3
_SSIM_SIGMA = 1.5
_SSIM_K1 = 0.01
_SSIM_K2 = 0.03

VGG16_WEIGHTS_ENV = "VTO_VGG16_WEIGHTS"
VGG16_WEIGHTS_FILENAME = "vgg16-397923af.pth"
# torchvision's VGG16 'features' layout: conv widths and 'M' for a 2x2 max pool.
_VGG16_CONFIG = [64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M", 512, 512, 512, "M"]
# Indices in 'features' of relu1_2, relu2_2 and relu3_3.
_VGG_FEATURE_LAYERS = (3, 8, 15)
_IMAGENET_MEAN = (0.485, 0.456, 0.406)
_IMAGENET_STD = (0.229, 0.224, 0.225)
_PERCEPTUAL_MODES = ("auto", "vgg", "ssim_l1")


def _shape(tensor):
    """The tensor's shape as a plain tuple, for messages."""
    return tuple(tensor.shape)


def sensitivity_loss(real_base, real_moved, fake_base, fake_moved):
    """Rendering sensitivity loss (paper eq. 3): renderer vs imitator finite differences.

    real_base, fake_base: (B, C, H, W) renders R(X, g) and I(X, g);
    real_moved, fake_moved: (B, m, C, H, W) renders with only parameter j moved.
    Squared error meaned over C, H, W, summed over j, meaned over B -> scalar.
    """
    if real_base.ndim != 4 or fake_base.shape != real_base.shape:
        raise VtoError(
            f"sensitivity_loss: base renders must both be (B, C, H, W), got"
            f" {_shape(real_base)} and {_shape(fake_base)}"
        )
    expected_moved = (real_base.shape[0], "m", *real_base.shape[1:])
    for name, moved in (("real_moved", real_moved), ("fake_moved", fake_moved)):
        if moved.ndim != 5 or moved.shape[0] != real_base.shape[0] or moved.shape[2:] != real_base.shape[1:]:
            raise VtoError(f"sensitivity_loss: {name} has shape {_shape(moved)}, expected {expected_moved}")
    if real_moved.shape != fake_moved.shape:
        raise VtoError(
            f"sensitivity_loss: real_moved {_shape(real_moved)} and fake_moved {_shape(fake_moved)} differ"
        )
    real_change = real_base.unsqueeze(1) - real_moved
    fake_change = fake_base.unsqueeze(1) - fake_moved
    per_parameter = (real_change - fake_change).square().mean(dim=(2, 3, 4))
    return per_parameter.sum(dim=1).mean()


def parameter_difference(g_true, g_pred, wraps=None):
    """g_pred - g_true: (B, m); dimensions flagged in `wraps` (m,) bool (hue) on the circle, in [-0.5, 0.5)."""
    difference = g_pred - g_true
    if wraps is not None and any(wraps):
        mask = torch.as_tensor(wraps, dtype=torch.bool, device=difference.device)
        difference = torch.where(mask, torch.remainder(difference + 0.5, 1.0) - 0.5, difference)
    return difference


def graphics_loss(g_true, g_pred, wraps=None, error="squared", weights=None):
    """g_true, g_pred: (B, m) -> scalar mean over B of the weighted sum of per-parameter errors.

    error: "squared" (the paper) or "absolute" (whose minimiser is the median of what a render allows, not the mean)
    for every parameter, or (m,) bools, True where a parameter's error is absolute (graphics_errors);
    weights: (m,) or None for all 1; wrapping dims are on the circle.
    """
    if g_true.ndim != 2 or g_true.shape != g_pred.shape:
        raise VtoError(
            f"graphics_loss: expected two (B, m) tensors of one shape, got {_shape(g_true)} and {_shape(g_pred)}"
        )
    if isinstance(error, str):
        if error not in ("squared", "absolute"):
            raise VtoError(f"graphics_loss: error must be squared or absolute, got '{error}'")
        error = [error == "absolute"] * g_true.shape[1]
    if len(error) != g_true.shape[1]:
        raise VtoError(f"graphics_loss: {len(error)} per-parameter errors for {g_true.shape[1]} parameters")
    difference = parameter_difference(g_true, g_pred, wraps)
    absolute = torch.as_tensor(list(error), dtype=torch.bool, device=difference.device)
    per_parameter = torch.where(absolute, difference.abs(), difference.square())
    if weights is not None:
        per_parameter = per_parameter * torch.as_tensor(weights, dtype=per_parameter.dtype, device=per_parameter.device)
    return per_parameter.sum(dim=1).mean()


COLOUR_UNIT = 10.0  # CIELAB units: a colour-statistics difference of this size costs as a unit parameter error does


def colour_loss(colour_net, g_true, g_pred):
    """What the estimate shows against what the truth shows: mean squared difference of the colour imitator's
    statistics (CIELAB, training.train_colour.ColourNet, frozen) of (B, m) unit parameters, in COLOUR_UNITs."""
    return ((colour_net(g_pred.clamp(0.0, 1.0)) - colour_net(g_true)) / COLOUR_UNIT).square().mean()


def graphics_errors(error: str, absolute: str, names: list[str]) -> str | list[bool]:
    """The graphics loss's error: `error` ('squared' or 'absolute') for every parameter where `absolute` is empty, else
    (m,) bools, True for the parameters it names ('name,...') and for the rest where `error` is 'absolute'."""
    if not absolute.strip():
        return error
    named = [item.strip() for item in absolute.split(",")]
    unknown = [name for name in named if name not in names]
    if unknown:
        raise VtoError(f"absolute_parameters: {', '.join(unknown)} not among {', '.join(names)}")
    return [name in named or error == "absolute" for name in names]


def parameter_weights(setting: str, names: list[str]) -> list[float] | None:
    """'name=weight,...' -> a weight per name in `names` (1 where not named), or None for an empty setting."""
    if not setting.strip():
        return None
    weights = dict.fromkeys(names, 1.0)
    for item in setting.split(","):
        name, sep, text = item.strip().partition("=")
        try:
            value = float(text) if sep else math.nan
        except ValueError:
            value = math.nan
        if name not in weights or not 0.0 <= value < math.inf:
            raise VtoError(f"parameter_weights: '{item.strip()}' is not name=weight with a weight of at least 0 for "
                           f"one of {', '.join(names)}")
        weights[name] = value
    return [weights[name] for name in names]


def weighted_total(terms):
    """{name: (unweighted scalar tensor, weight)} -> (log dict, total = sum of weight x term).

    The log dict (detached) holds every term as `name` and `name_weighted`, and `total`: each term's magnitude and
    its share of the total are in the run's losses.jsonl.
    """
    losses, total = {}, 0.0
    for name, (value, weight) in terms.items():
        weighted = weight * value
        total = total + weighted
        losses[name], losses[f"{name}_weighted"] = value.detach(), weighted.detach()
    losses["total"] = total.detach()
    return losses, total


def gradient_penalty(critic, real, fake):
    """WGAN-GP penalty E[(||grad critic(interp)|| - 1)^2] on random real/fake mixes; real, fake: (B, ...)."""
    if real.shape != fake.shape:
        raise VtoError(f"gradient_penalty: real {_shape(real)} and fake {_shape(fake)} differ")
    alpha_shape = (real.shape[0],) + (1,) * (real.ndim - 1)
    alpha = torch.rand(alpha_shape, device=real.device, dtype=real.dtype)
    interpolated = (alpha * real + (1 - alpha) * fake).detach().requires_grad_(True)
    (gradients,) = torch.autograd.grad(critic(interpolated).sum(), interpolated, create_graph=True)
    return (gradients.flatten(1).norm(dim=1) - 1).square().mean()


def critic_loss(critic, real, fake, lambda_gp=10.0):
    """WGAN-GP critic loss critic(fake) - critic(real) + lambda_gp * penalty; real, fake: (B, C, H, W)."""
    fake = fake.detach()
    wasserstein = critic(fake).mean() - critic(real).mean()
    return wasserstein + lambda_gp * gradient_penalty(critic, real, fake)


def generator_adversarial_loss(critic, fake):
    """WGAN generator loss -critic(fake).mean(); fake: (B, C, H, W)."""
    return -critic(fake).mean()


def _gaussian_window(size, sigma, dtype, device):
    """Normalised 1-D Gaussian weights (size,) centred on the middle tap."""
    offsets = torch.arange(size, dtype=dtype, device=device) - (size - 1) / 2.0
    weights = torch.exp(-(offsets**2) / (2.0 * sigma**2))
    return weights / weights.sum()


def ssim(x, y, data_range=1.0):
    """Differentiable SSIM of x, y (B, C, H, W) -> (B,), matching vto_core.metrics.ssim per image.

    Gaussian 11x11 window (sigma 1.5) on valid positions only, per-channel means
    averaged; images under 11 px use the largest odd window that fits (min 3).
    """
    if x.ndim != 4 or x.shape != y.shape:
        raise VtoError(f"ssim: expected two (B, C, H, W) tensors of one shape, got {_shape(x)} and {_shape(y)}")
    if not data_range > 0:
        raise VtoError(f"ssim: data_range must be positive, got {data_range}")
    channels = x.shape[1]
    shortest_side = min(x.shape[2], x.shape[3])
    if shortest_side < _SSIM_MIN_WINDOW_SIZE:
        raise VtoError(
            f"ssim: images of shape {_shape(x)} are smaller than the {_SSIM_MIN_WINDOW_SIZE}-px window"
        )
    window_size = min(_SSIM_WINDOW_SIZE, shortest_side if shortest_side % 2 else shortest_side - 1)
    window = _gaussian_window(window_size, _SSIM_SIGMA, x.dtype, x.device)
    # Separable depthwise filtering: one vertical then one horizontal pass per channel.
    vertical = window.view(1, 1, window_size, 1).expand(channels, 1, window_size, 1)
    horizontal = window.view(1, 1, 1, window_size).expand(channels, 1, 1, window_size)

    def local_mean(image):
        return F.conv2d(F.conv2d(image, vertical, groups=channels), horizontal, groups=channels)

    c1 = (_SSIM_K1 * data_range) ** 2
    c2 = (_SSIM_K2 * data_range) ** 2
    mean_x = local_mean(x)
    mean_y = local_mean(y)
    variance_x = local_mean(x * x) - mean_x**2
    variance_y = local_mean(y * y) - mean_y**2
    covariance = local_mean(x * y) - mean_x * mean_y
    ssim_map = ((2 * mean_x * mean_y + c1) * (2 * covariance + c2)) / (
        (mean_x**2 + mean_y**2 + c1) * (variance_x + variance_y + c2)
    )
    return ssim_map.mean(dim=(2, 3)).mean(dim=1)


def _vgg16_features():
    """torchvision's VGG16 'features' stack (conv 3x3 pad 1 + ReLU, 2x2 max pools), untrained."""
    layers = []
    channels = 3
    for entry in _VGG16_CONFIG:
        if entry == "M":
            layers.append(nn.MaxPool2d(kernel_size=2, stride=2))
        else:
            layers += [nn.Conv2d(channels, entry, kernel_size=3, padding=1), nn.ReLU(inplace=False)]
            channels = entry
    return nn.Sequential(*layers)


def vgg16_weight_candidates():
    """Where VGG16 weights are looked for, in order: $VTO_VGG16_WEIGHTS, then the torch hub cache."""
    candidates = []
    from_environment = os.environ.get(VGG16_WEIGHTS_ENV)
    if from_environment:
        candidates.append(Path(from_environment).expanduser())
    torch_home = Path(os.environ.get("TORCH_HOME", Path.home() / ".cache" / "torch")).expanduser()
    candidates.append(torch_home / "hub" / "checkpoints" / VGG16_WEIGHTS_FILENAME)
    return candidates


def _find_vgg16_weights(weights_path):
    """Return (the weights file or None, the places looked at) for an explicit path or the defaults."""
    if weights_path is not None:
        path = Path(weights_path).expanduser()
        if not path.is_file():
            raise VtoError(f"PerceptualDistance: VGG16 weights file {path} does not exist")
        return path, [path]
    candidates = vgg16_weight_candidates()
    found = next((path for path in candidates if path.is_file()), None)
    return found, candidates


def _load_vgg16_features(features, path):
    """Load the 'features.*' tensors of a torchvision vgg16 state dict file into features."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch.load raises many types for a bad file
        raise VtoError(f"PerceptualDistance: cannot read VGG16 weights {path}: {error}") from None
    if not isinstance(state, dict):
        raise VtoError(f"PerceptualDistance: {path} does not hold a state dict")
    prefix = "features."
    feature_state = {key[len(prefix) :]: value for key, value in state.items() if key.startswith(prefix)}
    try:
        features.load_state_dict(feature_state, strict=True)
    except RuntimeError as error:
        first_line = str(error).strip().splitlines()[0]
        raise VtoError(f"PerceptualDistance: {path} is not a torchvision VGG16 state dict: {first_line}") from None


class PerceptualDistance(nn.Module):
    """Frozen perceptual distance: VGG16 relu1_2/2_2/3_3 feature MSE, or SSIM+L1 without weights."""

    def __init__(self, mode="auto", weights_path=None):
        super().__init__()
        if mode not in _PERCEPTUAL_MODES:
            raise VtoError(f"PerceptualDistance: unknown mode {mode!r}, expected one of {_PERCEPTUAL_MODES}")
        self.weights_path = None
        self.features = None
        if mode == "ssim_l1":
            self.kind = "ssim_l1"
        else:
            found, looked_at = _find_vgg16_weights(weights_path)
            places = ", ".join(str(path) for path in looked_at)
            if found is not None:
                self.kind = "vgg"
                self.weights_path = found
                self.features = _vgg16_features()
                _load_vgg16_features(self.features, found)
            elif mode == "vgg":
                raise VtoError(
                    f"PerceptualDistance: no VGG16 weights found (looked at {places});"
                    f" set {VGG16_WEIGHTS_ENV} to a torchvision vgg16 .pth file"
                )
            else:
                self.kind = "ssim_l1"
                warnings.warn(
                    f"PerceptualDistance: no VGG16 weights found (looked at {places}); the"
                    f" perceptual loss falls back to SSIM+L1. Set {VGG16_WEIGHTS_ENV} to a"
                    " torchvision vgg16 .pth file to use VGG features.",
                    stacklevel=2,
                )
        self.register_buffer("mean", torch.tensor(_IMAGENET_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(_IMAGENET_STD).view(1, 3, 1, 1), persistent=False)
        self.requires_grad_(False)
        self.eval()

    def train(self, mode=True):
        """Stay in eval mode: this is a fixed measure, never trained."""
        return super().train(False)

    def _vgg_distance(self, x, y):
        """Sum over relu1_2, relu2_2, relu3_3 of the mean squared feature difference."""
        features_x = (x - self.mean) / self.std
        features_y = (y - self.mean) / self.std
        distance = x.new_zeros(())
        for index, layer in enumerate(self.features[: _VGG_FEATURE_LAYERS[-1] + 1]):
            features_x = layer(features_x)
            features_y = layer(features_y)
            if index in _VGG_FEATURE_LAYERS:
                distance = distance + (features_x - features_y).square().mean()
        return distance

    def forward(self, x, y):
        """x, y: (B, 3, H, W) in [0,1] -> scalar distance, meaned over the batch."""
        if x.ndim != 4 or x.shape != y.shape or x.shape[1] != 3:
            raise VtoError(
                f"PerceptualDistance: expected two (B, 3, H, W) tensors of one shape, got {_shape(x)} and {_shape(y)}"
            )
        if self.kind == "vgg":
            return self._vgg_distance(x, y)
        return (1 - ssim(x, y)).mean() + (x - y).abs().mean()
