"""Tests for training.networks: imitator, critic, encoder shapes, checks and build()."""

import pytest

pytestmark = pytest.mark.torch
torch = pytest.importorskip("torch")

from training.networks import Critic, Encoder, Imitator, MirrorAveraged, build  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """Tiny tensors: one thread avoids thread-pool contention on busy machines."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


def _images(batch, size, channels=3, seed=0):
    """Reproducible random images (batch, channels, size, size) in [0, 1]."""
    generator = torch.Generator().manual_seed(seed)
    return torch.rand(batch, channels, size, size, generator=generator)


def _params(batch, n_params, seed=1):
    """Reproducible random normalised parameters (batch, n_params) in [0, 1]."""
    generator = torch.Generator().manual_seed(seed)
    return torch.rand(batch, n_params, generator=generator)


@pytest.mark.parametrize("size", [16, 32])
@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize(("width", "n_down", "n_res"), [(4, 1, 1), (8, 2, 2), (4, 3, 0)])
def test_imitator_keeps_image_shape(size, batch, width, n_down, n_res):
    imitator = Imitator(n_params=5, width=width, n_down=n_down, n_res=n_res)
    x = _images(batch, size)
    g = _params(batch, 5)
    output = imitator(x, g)
    difference = imitator.difference(x, g)
    assert output.shape == (batch, 3, size, size)
    assert difference.shape == (batch, 3, size, size)
    assert difference.abs().max() <= 1.0
    assert torch.allclose(output, x + difference)


def test_imitator_bottleneck_channels_double_per_halving():
    imitator = Imitator(n_params=2, width=4, n_down=2, n_res=1)
    widest = max(m.out_channels for m in imitator.modules() if isinstance(m, torch.nn.Conv2d))
    assert widest == 16
    assert imitator.to_difference.in_channels == 4


def test_imitator_with_zeroed_last_conv_returns_its_input_exactly():
    imitator = Imitator(n_params=3, width=4, n_down=2, n_res=1)
    with torch.no_grad():
        imitator.to_difference.weight.zero_()
        imitator.to_difference.bias.zero_()
    x = _images(2, 16)
    assert torch.equal(imitator(x, _params(2, 3)), x)


def test_imitator_output_depends_on_parameters():
    imitator = Imitator(n_params=3, width=4, n_down=1, n_res=1)
    x = _images(1, 16)
    first = imitator(x, torch.zeros(1, 3))
    second = imitator(x, torch.ones(1, 3))
    assert (first - second).abs().max() > 1e-6


@pytest.mark.parametrize(("height", "width"), [(18, 16), (16, 20), (15, 15)])
def test_imitator_refuses_sizes_not_divisible_by_its_halvings(height, width):
    imitator = Imitator(n_params=2, width=4, n_down=3, n_res=1)
    x = torch.rand(1, 3, height, width)
    with pytest.raises(VtoError, match=f"{height}x{width}"):
        imitator(x, torch.rand(1, 2))


def test_imitator_refuses_wrong_parameter_count():
    imitator = Imitator(n_params=2, width=4, n_down=1, n_res=1)
    with pytest.raises(VtoError, match="g of shape"):
        imitator(_images(1, 16), torch.rand(1, 3))


def test_imitator_refuses_bad_constructor_arguments():
    with pytest.raises(VtoError, match="n_params"):
        Imitator(n_params=0)


@pytest.mark.parametrize("size", [16, 32])
@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize(("width", "n_layers"), [(4, 1), (8, 3), (4, 4)])
def test_critic_scores_one_number_per_image(size, batch, width, n_layers):
    critic = Critic(width=width, n_layers=n_layers)
    scores = critic(_images(batch, size))
    assert scores.shape == (batch,)
    assert torch.isfinite(scores).all()


def test_critic_score_is_the_mean_of_its_patch_map():
    critic = Critic(width=4, n_layers=2)
    x = _images(2, 16)
    patch_map = critic.body(x)
    assert patch_map.shape == (2, 1, 4, 4)
    assert torch.allclose(critic(x), patch_map.mean(dim=(1, 2, 3)))


def test_critic_has_no_normalisation_layers_and_caps_channels():
    critic = Critic(width=4, n_layers=6)
    assert not any(isinstance(m, (torch.nn.InstanceNorm2d, torch.nn.BatchNorm2d)) for m in critic.modules())
    widths = [m.out_channels for m in critic.modules() if isinstance(m, torch.nn.Conv2d)]
    assert widths == [4, 8, 16, 32, 32, 32, 1]


@pytest.mark.parametrize(("size", "n_layers"), [(8, 4), (16, 5), (2, 2)])
def test_critic_refuses_inputs_that_shrink_below_one_pixel(size, n_layers):
    critic = Critic(width=4, n_layers=n_layers)
    with pytest.raises(VtoError, match="below 1 px"):
        critic(_images(1, size))


@pytest.mark.parametrize("size", [16, 32])
@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize(("width", "n_layers", "pool_size"), [(4, 2, 4), (8, 4, 1), (4, 3, 2)])
def test_encoder_outputs_one_parameter_vector_per_image(size, batch, width, n_layers, pool_size):
    encoder = Encoder(n_params=7, width=width, n_layers=n_layers, pool_size=pool_size)
    output = encoder(_images(batch, size))
    assert output.shape == (batch, 7)
    assert torch.isfinite(output).all()


def test_encoder_uses_only_exportable_layers():
    encoder = Encoder(n_params=3, width=4, n_layers=2, pool_size=2)
    allowed = (torch.nn.Conv2d, torch.nn.ReLU, torch.nn.AdaptiveAvgPool2d, torch.nn.Flatten, torch.nn.Linear)
    leaves = [m for m in encoder.modules() if not list(m.children())]
    assert leaves and all(isinstance(m, allowed) for m in leaves)
    assert encoder.body[-1].in_features == 8 * 2 * 2


def test_encoder_blocks_and_batch_norm_add_same_size_stages():
    plain = Encoder(n_params=3, width=4, n_layers=2, pool_size=2)
    deep = Encoder(n_params=3, width=4, n_layers=2, pool_size=2, blocks=2, batch_norm=1)
    convs = [m for m in deep.modules() if isinstance(m, torch.nn.Conv2d)]
    assert len(convs) == 2 * 3 and sum(isinstance(m, torch.nn.BatchNorm2d) for m in deep.modules()) == 6
    assert all(c.bias is None for c in convs) and all(c.bias is not None for c in plain.modules()
                                                      if isinstance(c, torch.nn.Conv2d))
    assert deep(_images(2, 16)).shape == (2, 3)
    with pytest.raises(VtoError, match="batch_norm must be 0 or 1"):
        Encoder(n_params=3, batch_norm=2)
    with pytest.raises(VtoError, match="blocks"):
        Encoder(n_params=3, blocks=-1)


def test_encoder_input_filter_reads_the_image_box_filtered_with_edges_repeated():
    plain = Encoder(n_params=3, width=4, n_layers=2, pool_size=2)
    filtered = Encoder(n_params=3, width=4, n_layers=2, pool_size=2, input_filter=3)
    filtered.load_state_dict(plain.state_dict())  # the filter has no weights
    assert build("encoder", filtered.model_args).input_filter == 3
    images = _images(2, 16)
    padded = torch.nn.functional.pad(images, (1, 1, 1, 1), mode="replicate")
    boxed = sum(padded[:, :, dy:dy + 16, dx:dx + 16] for dy in range(3) for dx in range(3)) / 9.0
    with torch.no_grad():
        assert torch.allclose(filtered(images), plain(boxed), atol=1e-6)
        assert not torch.allclose(filtered(images), plain(images), atol=1e-4)
        constant = torch.full((1, 3, 16, 16), 0.7)  # a flat image is its own box filter, at the edges too
        assert torch.allclose(filtered(constant), plain(constant), atol=1e-6)
    for bad in (1, 2, 4):
        with pytest.raises(VtoError, match="input_filter must be 0 or an odd size"):
            Encoder(n_params=3, input_filter=bad)


def test_encoder_refuses_wrong_channels_and_tiny_images():
    encoder = Encoder(n_params=3, width=4, n_layers=4)
    with pytest.raises(VtoError, match=r"\(B, 3, H, W\)"):
        encoder(torch.rand(1, 1, 16, 16))
    with pytest.raises(VtoError, match="below 1 px"):
        encoder(_images(1, 8))


def test_mirror_averaging_is_the_mean_of_both_readings_and_wraps_hue_on_the_circle():
    torch.manual_seed(0)
    encoder = Encoder(n_params=3, width=4, n_layers=2).eval()
    images = _images(4, 16)
    with torch.no_grad():
        averaged = MirrorAveraged(encoder, [False, False, False])(images)
        expected = 0.5 * (encoder(images) + encoder(images.flip(-1)))
    assert torch.allclose(averaged, expected, atol=1e-6)
    with torch.no_grad():  # a symmetric image reads the same both ways
        symmetric = images + images.flip(-1)
        assert torch.allclose(MirrorAveraged(encoder, [False] * 3)(symmetric), encoder(symmetric), atol=1e-6)

    class CornerReader(torch.nn.Module):  # reads the top-left pixel's three channels as the estimate
        def forward(self, img):
            return img[:, :, 0, 0]

    image = torch.zeros(1, 3, 2, 2)
    image[0, :, 0, 0] = torch.tensor([0.95, 0.95, 0.3])  # left: mirrored, the reading comes from the right pixel
    image[0, :, 0, 1] = torch.tensor([0.05, 0.05, 0.5])
    read = MirrorAveraged(CornerReader(), [True, False, False])(image)[0]
    assert read[0] == pytest.approx(1.0, abs=1e-6)  # 0.95 and 0.05 meet at 0 = 1 on the circle, not at 0.5
    assert read[1] == pytest.approx(0.5) and read[2] == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("kind", "network_class", "model_args", "inputs"),
    [
        ("imitator", Imitator, dict(n_params=3, width=4, n_down=2, n_res=1), (_images(2, 16), _params(2, 3))),
        ("critic", Critic, dict(width=4, n_layers=3), (_images(2, 16),)),
        ("encoder", Encoder, dict(n_params=3, width=4, n_layers=2, pool_size=2), (_images(2, 16),)),
        ("encoder", Encoder, dict(n_params=3, width=4, n_layers=2, blocks=1, batch_norm=1), (_images(2, 16),)),
    ],
)
def test_build_round_trips_model_args(kind, network_class, model_args, inputs):
    torch.manual_seed(0)
    original = network_class(**model_args)
    assert isinstance(original.model_args, dict)
    rebuilt = build(kind, original.model_args)
    assert type(rebuilt) is network_class
    assert rebuilt.model_args == original.model_args
    assert list(rebuilt.state_dict()) == list(original.state_dict())
    rebuilt.load_state_dict(original.state_dict())
    assert torch.equal(rebuilt(*inputs), original(*inputs))


def test_model_args_hold_the_defaults_too():
    assert Imitator(n_params=4).model_args == dict(n_params=4, width=64, n_down=2, n_res=6, image_channels=3)
    assert Critic().model_args == dict(width=64, n_layers=4, image_channels=3)
    assert Encoder(n_params=4).model_args == dict(
        n_params=4, width=32, n_layers=4, image_channels=3, pool_size=4, blocks=0, batch_norm=0, input_filter=0
    )


def test_build_refuses_unknown_kind_and_arguments():
    with pytest.raises(VtoError, match="unknown network kind 'decoder'"):
        build("decoder", {})
    with pytest.raises(VtoError, match="bad model_args"):
        build("critic", {"depth": 3})


def test_model_args_are_plain_ints_even_from_numpy_integers():
    np = pytest.importorskip("numpy")
    imitator = Imitator(n_params=np.int64(4), width=np.int32(4), n_down=1, n_res=1)
    assert all(type(value) is int for value in imitator.model_args.values())
    with pytest.raises(VtoError, match="width"):
        Critic(width=2.0)
