"""The imitator, critic and inverse-graphics encoder networks (Kips et al. 2022, section 6)."""

import numbers

import torch
from torch import nn

from vto_core.errors import VtoError

from .losses import parameter_difference


def _check_count(owner, name, value, minimum):
    """Return value as a plain int, raising VtoError unless it is an integer (not bool) >= minimum."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise VtoError(f"{owner}: {name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _model_args(owner, minimums=None, **counts):
    """The checked constructor arguments as plain ints (minimum 1 unless `minimums` says otherwise)."""
    minimums = minimums or {}
    return {name: _check_count(owner, name, value, minimums.get(name, 1)) for name, value in counts.items()}


def _check_images(owner, images, image_channels):
    """Raise VtoError unless images is (B, image_channels, H, W)."""
    if images.ndim != 4 or images.shape[1] != image_channels:
        raise VtoError(
            f"{owner}: expected images of shape (B, {image_channels}, H, W), got {tuple(images.shape)}"
        )


def _check_halvings(owner, images, n_halvings):
    """Raise VtoError if n_halvings stride-2 convolutions would shrink images below 1 px."""
    height, width = images.shape[-2:]
    smallest = 2**n_halvings
    if height < smallest or width < smallest:
        raise VtoError(
            f"{owner}: {height}x{width} images shrink below 1 px after {n_halvings} halvings;"
            f" they need at least {smallest}x{smallest}"
        )


def _down_channels(width, level):
    """Channels of the level-th stride-2 stage: width * 2**level, capped at 8 * width."""
    return min(width * 2**level, 8 * width)


class _ResidualBlock(nn.Module):
    """x + [pad, conv 4x4, IN, ReLU, pad, conv 4x4, IN](x), same size and channels."""

    def __init__(self, channels):
        super().__init__()
        # A 4x4 kernel is even, so 'same' size needs asymmetric padding: 1 before, 2 after.
        self.body = nn.Sequential(
            nn.ZeroPad2d((1, 2, 1, 2)),
            nn.Conv2d(channels, channels, 4, stride=1, padding=0, bias=False),
            nn.InstanceNorm2d(channels, affine=True),
            nn.ReLU(),
            nn.ZeroPad2d((1, 2, 1, 2)),
            nn.Conv2d(channels, channels, 4, stride=1, padding=0, bias=False),
            nn.InstanceNorm2d(channels, affine=True),
        )

    def forward(self, x):
        """x: (B, channels, H, W) -> (B, channels, H, W)."""
        return x + self.body(x)


class Imitator(nn.Module):
    """StarGAN-like generator I(x, g) = x + difference(x, g), a differentiable renderer surrogate."""

    def __init__(self, n_params, width=64, n_down=2, n_res=6, image_channels=3):
        super().__init__()
        self.model_args = _model_args("Imitator", {"n_down": 0, "n_res": 0}, n_params=n_params, width=width,
                                      n_down=n_down, n_res=n_res, image_channels=image_channels)
        n_params, width, n_down, n_res, image_channels = self.model_args.values()
        self.n_params = n_params
        self.n_down = n_down
        self.image_channels = image_channels

        # Convolutions followed by InstanceNorm carry no bias: the norm's shift replaces it.
        layers = [
            nn.Conv2d(image_channels + n_params, width, 7, stride=1, padding=3, bias=False),
            nn.InstanceNorm2d(width, affine=True),
            nn.ReLU(),
        ]
        channels = width
        for _ in range(n_down):
            layers += [
                nn.Conv2d(channels, channels * 2, 4, stride=2, padding=1, bias=False),
                nn.InstanceNorm2d(channels * 2, affine=True),
                nn.ReLU(),
            ]
            channels *= 2
        layers += [_ResidualBlock(channels) for _ in range(n_res)]
        for _ in range(n_down):
            layers += [
                nn.ConvTranspose2d(channels, channels // 2, 4, stride=2, padding=1, bias=False),
                nn.InstanceNorm2d(channels // 2, affine=True),
                nn.ReLU(),
            ]
            channels //= 2
        self.body = nn.Sequential(*layers)
        self.to_difference = nn.Conv2d(channels, image_channels, 7, stride=1, padding=3)

    def _check_inputs(self, x, g):
        """Raise VtoError unless x is (B, C, H, W) with H, W divisible by 2**n_down and g is (B, m)."""
        _check_images("Imitator", x, self.image_channels)
        if g.ndim != 2 or g.shape != (x.shape[0], self.n_params):
            raise VtoError(
                f"Imitator: expected g of shape ({x.shape[0]}, {self.n_params}), got {tuple(g.shape)}"
            )
        height, width = x.shape[-2:]
        factor = 2**self.n_down
        if height % factor or width % factor:
            raise VtoError(
                f"Imitator: image size {height}x{width} is not divisible by 2**n_down = {factor}"
            )
        # InstanceNorm cannot normalise a single pixel.
        if height * width // factor**2 < 2:
            raise VtoError(
                f"Imitator: image size {height}x{width} leaves a 1-pixel bottleneck after"
                f" {self.n_down} halvings; use larger images"
            )

    def difference(self, x, g):
        """x: (B, C, H, W), g: (B, m) -> the difference map (B, C, H, W) in [-1, 1]."""
        self._check_inputs(x, g)
        g_planes = g[:, :, None, None].to(x.dtype).expand(-1, -1, x.shape[2], x.shape[3])
        features = self.body(torch.cat([x, g_planes], dim=1))
        return torch.tanh(self.to_difference(features))

    def forward(self, x, g):
        """x: (B, C, H, W), g: (B, m) normalised parameters -> rendered estimate x + difference."""
        return x + self.difference(x, g)


class Critic(nn.Module):
    """WGAN-GP patch critic without normalisation layers: img (B, C, H, W) -> score (B,)."""

    def __init__(self, width=64, n_layers=4, image_channels=3):
        super().__init__()
        self.model_args = _model_args("Critic", width=width, n_layers=n_layers, image_channels=image_channels)
        width, n_layers, image_channels = self.model_args.values()
        self.n_layers = n_layers
        self.image_channels = image_channels

        layers = []
        channels = image_channels
        for level in range(n_layers):
            out_channels = _down_channels(width, level)
            layers += [nn.Conv2d(channels, out_channels, 4, stride=2, padding=1), nn.LeakyReLU(0.01)]
            channels = out_channels
        layers.append(nn.Conv2d(channels, 1, 3, stride=1, padding=1))
        self.body = nn.Sequential(*layers)

    def forward(self, img):
        """img: (B, C, H, W) -> (B,) mean of the patch score map."""
        _check_images("Critic", img, self.image_channels)
        _check_halvings("Critic", img, self.n_layers)
        return self.body(img).mean(dim=(1, 2, 3))


class Encoder(nn.Module):
    """Inverse-graphics encoder E: img (B, C, H, W) in [0,1] -> normalised parameters (B, m).

    Each of the n_layers levels is a stride-2 4x4 convolution followed by `blocks` 3x3 convolutions at the same size;
    batch_norm=1 puts a BatchNorm after every convolution (folded into it on export). input_filter=k (odd, >= 3) reads
    the image box-filtered over k x k pixels, edges repeated: the first convolution strides by 2, so without it a
    framing one pixel off reads another estimate (lipstick_encoder.md).
    """

    def __init__(self, n_params, width=32, n_layers=4, image_channels=3, pool_size=4, blocks=0, batch_norm=0,
                 input_filter=0):
        super().__init__()
        self.model_args = _model_args("Encoder", {"blocks": 0, "batch_norm": 0, "input_filter": 0}, n_params=n_params,
                                      width=width, n_layers=n_layers, image_channels=image_channels,
                                      pool_size=pool_size, blocks=blocks, batch_norm=batch_norm,
                                      input_filter=input_filter)
        n_params, width, n_layers, image_channels, pool_size, blocks, batch_norm, input_filter = \
            self.model_args.values()
        if batch_norm > 1:
            raise VtoError(f"Encoder: batch_norm must be 0 or 1, got {batch_norm}")
        if input_filter and (input_filter < 3 or input_filter % 2 == 0):
            raise VtoError(f"Encoder: input_filter must be 0 or an odd size >= 3, got {input_filter}")
        self.input_filter = input_filter
        self.n_layers = n_layers
        self.image_channels = image_channels

        def stage(channels_in, channels_out, kernel, stride, padding):
            conv = nn.Conv2d(channels_in, channels_out, kernel, stride=stride, padding=padding, bias=not batch_norm)
            return [conv, nn.BatchNorm2d(channels_out), nn.ReLU()] if batch_norm else [conv, nn.ReLU()]

        layers = []
        channels = image_channels
        for level in range(n_layers):
            out_channels = _down_channels(width, level)
            layers += stage(channels, out_channels, 4, 2, 1)
            for _ in range(blocks):
                layers += stage(out_channels, out_channels, 3, 1, 1)
            channels = out_channels
        # Plain ops only, so the network exports to ONNX; the pool's output size should divide
        # the final feature map (image size / 2**n_layers) for the export to be a plain average.
        layers += [
            nn.AdaptiveAvgPool2d(pool_size),
            nn.Flatten(),
            nn.Linear(channels * pool_size * pool_size, n_params),
        ]
        self.body = nn.Sequential(*layers)

    def forward(self, img):
        """img: (B, C, H, W) in [0,1] -> (B, n_params) linear outputs."""
        _check_images("Encoder", img, self.image_channels)
        _check_halvings("Encoder", img, self.n_layers)
        if self.input_filter:
            half = self.input_filter // 2
            img = nn.functional.avg_pool2d(nn.functional.pad(img, (half,) * 4, mode="replicate"), self.input_filter,
                                           stride=1)
        return self.body(img)


class MirrorAveraged(nn.Module):
    """An encoder read on an image and on its left-right mirror, the two estimates averaged (wrapping outputs, such as
    hue, on the circle): for an encoder trained on mirrored views, whose two readings differ only by its error.
    img (B, C, H, W) -> (B, n_params); `wraps` (n_params,) bool."""

    def __init__(self, encoder, wraps):
        super().__init__()
        self.encoder, self.wraps = encoder, [bool(w) for w in wraps]

    def forward(self, img):
        """img: (B, C, H, W) in [0,1] -> (B, n_params), the mean of the two readings."""
        direct, mirrored = self.encoder(img), self.encoder(torch.flip(img, dims=[3]))
        return direct + 0.5 * parameter_difference(direct, mirrored, self.wraps)  # half-way, round the circle too


class Averaged(nn.Module):
    """Several encoders of one spec read on one image, their estimates averaged (wrapping outputs on the circle, round
    the first's): runs trained apart err apart, so their mean errs less. img (B, C, H, W) -> (B, n_params)."""

    def __init__(self, encoders, wraps):
        super().__init__()
        self.encoders, self.wraps = nn.ModuleList(encoders), [bool(w) for w in wraps]

    def forward(self, img):
        """img: (B, C, H, W) in [0,1] -> (B, n_params), the mean of the encoders' readings."""
        readings = [encoder(img) for encoder in self.encoders]
        first = readings[0]
        return first + sum(parameter_difference(first, other, self.wraps) for other in readings[1:]) / len(readings)


_NETWORK_CLASSES = {"imitator": Imitator, "critic": Critic, "encoder": Encoder}


def build(kind, model_args):
    """Rebuild a network of kind 'imitator', 'critic' or 'encoder' from its model_args dict."""
    network_class = _NETWORK_CLASSES.get(kind)
    if network_class is None:
        raise VtoError(f"build: unknown network kind {kind!r}, expected one of {sorted(_NETWORK_CLASSES)}")
    try:
        return network_class(**dict(model_args))
    except TypeError as error:
        raise VtoError(f"build: bad model_args for {kind!r}: {error}") from None
