"""training.data.augment: the views keep source and render aligned and change no pixel value or parameter."""

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
