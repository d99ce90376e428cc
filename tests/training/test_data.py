"""training.data views: augment keeps source and render aligned and every pixel value; photo_views keeps colour; open
mouths paint teeth on the mouth line; skin texture keeps colour on average."""

import pytest

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.torch

from training.data import augment  # noqa: E402


def test_source_and_render_move_together_and_keep_their_pixels():
    torch.manual_seed(0)
    render = torch.rand(64, 3, 8, 8)
    batch = {"source": render * 0.5, "render": render, "g": torch.rand(64, 4)}
    views = augment(batch)
    assert torch.equal(views["source"], views["render"] * 0.5)  # the same flip and shift for both
    assert torch.equal(views["g"], batch["g"])
    assert any(not torch.equal(a, b) for a, b in zip(views["render"], render))
    for before, after in zip(render, views["render"]):  # a mirror and a wrapping shift only permute pixels
        assert torch.equal(before.flatten().sort().values, after.flatten().sort().values)


def test_no_shift_keeps_or_mirrors_each_sample_exactly():
    torch.manual_seed(1)
    render = torch.rand(32, 3, 4, 6)
    views = augment({"render": render}, max_shift=0)["render"]
    mirrored = [torch.equal(v, r.flip(-1)) for v, r in zip(views, render)]
    kept = [torch.equal(v, r) for v, r in zip(views, render)]
    assert all(m or k for m, k in zip(mirrored, kept)) and 4 < sum(mirrored) < 28


def test_photo_views_keep_a_constant_image_and_the_parameters():
    from training.data import photo_views

    colour = torch.tensor([0.8, 0.1, 0.2]).view(1, 3, 1, 1)
    batch = {"render": colour.expand(6, 3, 16, 16).clone(), "g": torch.rand(6, 4)}
    views = photo_views(batch, max_noise=0.0)
    assert torch.allclose(views["render"], batch["render"], atol=1e-6)  # tilt, zoom and blur keep a flat colour
    assert torch.equal(views["g"], batch["g"])
    noisy = photo_views(batch, max_noise=0.05)["render"]
    assert torch.isfinite(noisy).all() and 0 <= noisy.min() and noisy.max() <= 1
    assert (noisy.mean(dim=(0, 2, 3)) - colour.view(3)).abs().max() < 0.01  # zero-mean noise


def test_photo_views_move_source_and_render_together_and_blur_only_the_render():
    from training.data import photo_views

    torch.manual_seed(0)
    image = torch.rand(4, 3, 24, 24)
    views = photo_views({"source": image.clone(), "render": image.clone()}, max_blur=0.0, max_noise=0.0)
    assert torch.allclose(views["source"], views["render"], atol=1e-6) and not torch.allclose(views["render"], image)
    blurred = photo_views({"source": image.clone(), "render": image.clone()}, max_tilt=0.0, zoom=(1.0, 1.0),
                          max_blur=1.0, max_noise=0.0)
    assert torch.allclose(blurred["source"], image, atol=1e-5)  # no tilt or zoom: the identity grid
    assert blurred["render"].std() < image.std()  # blur smooths the reference


def test_photo_views_at_their_extremes_stay_finite():
    from training.data import photo_views

    for render in (torch.zeros(2, 3, 8, 8), torch.ones(2, 3, 8, 8)):
        out = photo_views({"render": render}, max_tilt=3.1, zoom=(0.25, 4.0), max_blur=5.0, max_noise=1.0)["render"]
        assert torch.isfinite(out).all() and out.shape == render.shape


def test_open_mouths_paint_teeth_on_the_mouth_line_only_where_asked():
    from training.data import open_mouths

    torch.manual_seed(0)
    render = torch.full((8, 3, 32, 32), 0.5)
    render[:, :, 15, 8:24] = 0.0  # the mouth line, the darkest row near the centre
    batch = {"source": render.clone(), "render": render.clone(), "g": torch.rand(8, 4)}
    views = open_mouths(batch, chance=1.0)
    assert torch.equal(views["source"], views["render"]) and torch.equal(views["g"], batch["g"])
    changed = (views["render"] != render).any(dim=1)  # (B, H, W)
    rows = changed.any(dim=2).float()
    assert changed.flatten(1).any(dim=1).all()  # every sample got teeth
    assert rows[:, :8].sum() == 0 and rows[:, 24:].sum() == 0  # ... around row 15, nowhere near the top or bottom
    assert (views["render"][changed.unsqueeze(1).expand_as(render)] != 0.5).all()
    assert torch.equal(open_mouths(batch, chance=0.0)["render"], render)
    for image in (torch.zeros(2, 3, 4, 4), torch.ones(2, 3, 4, 4)):  # flat and tiny: still a mouth line to find
        out = open_mouths({"render": image}, chance=1.0)["render"]
        assert torch.isfinite(out).all() and 0 <= out.min() and out.max() <= 1


def test_skin_texture_keeps_colour_on_average_and_the_extremes_finite():
    from training.data import skin_texture

    torch.manual_seed(0)
    colour = torch.tensor([0.6, 0.3, 0.2]).view(1, 3, 1, 1)
    textured = skin_texture({"render": colour.expand(64, 3, 32, 32).clone()})["render"]
    assert textured.std() > 0.002  # texture is there
    assert (textured.mean(dim=(0, 2, 3)) - colour.view(3)).abs().max() < 0.005  # zero-mean gain
    assert torch.equal(skin_texture({"render": colour.expand(2, 3, 8, 8).clone()}, max_amplitude=0.0)["render"],
                       colour.expand(2, 3, 8, 8))
    for image in (torch.zeros(2, 3, 4, 4), torch.ones(2, 3, 4, 4)):  # flat, tiny: the noise is normalised safely
        out = skin_texture({"render": image}, max_amplitude=1.0)["render"]
        assert torch.isfinite(out).all() and 0 <= out.min() and out.max() <= 1
