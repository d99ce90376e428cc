"""The eye shadow on a photo (blender_addon.renderers.tryon, `vto tryon eyeshadow`): the node group rendered onto both
eyes' lids of a real portrait, the rest of the photo untouched."""

import json

import numpy as np
import pytest

pytest.importorskip("bpy")
pytestmark = pytest.mark.blender

from blender_addon.renderers.tryon import find_regions, tryon_product, tryon_view  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.colour import srgb_to_lab  # noqa: E402
from vto_core.imageio import read_image, resize, write_image  # noqa: E402
from vto_core.photo.face_reader import polygon_mask  # noqa: E402
from vto_core.photo.tryon import feathered  # noqa: E402
from vto_core.presets import load_presets  # noqa: E402
from vto_core.products import EYELIDS, EYESHADOW, LEFT_EYELID, get_spec  # noqa: E402

PRESETS = load_presets("eyeshadow")
SAMPLES = 8


@pytest.fixture(scope="module")
def astronaut():
    import skimage.data

    return skimage.data.astronaut().astype(np.float32) / 255  # public domain (NASA): Eileen Collins


def lid_masks(photo):
    """(each lid's mask (H, W) bool, where the try-on may reach: the lids' soft masks)."""
    found = find_regions(photo, EYESHADOW)
    masks = [polygon_mask(np.asarray(lid.outer), 0, 0, photo.shape[1], photo.shape[0]) for _, lid in found]
    return masks, np.any([feathered(mask) > 0 for mask in masks], axis=0)


def test_both_lids_wear_the_shade_and_nothing_else_changes(astronaut):
    assert [region for region, _ in find_regions(astronaut, EYESHADOW)] == [EYELIDS, LEFT_EYELID]
    masks, reach = lid_masks(astronaut)
    worn = tryon_product(EYESHADOW, astronaut, PRESETS["Royal Purple"], samples=SAMPLES)
    assert np.isfinite(worn).all() and worn.shape == astronaut.shape
    assert np.array_equal(worn[~reach], astronaut[~reach])  # off the lids: the photo, every pixel
    for mask in masks:  # each eye: bluer and more purple where the shadow lies (the band by the lashes)
        lab_worn, lab_photo = srgb_to_lab(worn[mask].mean(0)), srgb_to_lab(astronaut[mask].mean(0))
        assert lab_worn[2] < lab_photo[2] - 4 and lab_worn[0] < lab_photo[0]


def test_lightness_follows_the_shades_and_none_at_zero_opacity(astronaut):
    masks, _ = lid_masks(astronaut)
    inside = masks[0] | masks[1]
    lightness = {name: srgb_to_lab(tryon_product(EYESHADOW, astronaut, PRESETS[name], samples=SAMPLES)[inside]
                                   .mean(0))[0] for name in ("Jet Black", "Mocha Brown", "Vanilla Bone")}
    assert lightness["Jet Black"] < lightness["Mocha Brown"] - 5 < lightness["Vanilla Bone"] - 10
    bare = tryon_product(EYESHADOW, astronaut, {**PRESETS["Jet Black"], "opacity": 0.0}, samples=SAMPLES)
    assert np.abs(bare - astronaut).max() < 2e-3  # the same render bare and worn: a ratio of 1


def test_every_parameter_at_both_ends_gives_a_finite_try_on(astronaut):
    spec = get_spec("eyeshadow")
    for end in ("low", "high"):
        values = {p.name: getattr(p, end) for p in spec.params}
        crop = tryon_product(EYESHADOW, astronaut, values, crop=32, samples=2)
        assert crop.shape == (32, 32, 3) and np.isfinite(crop).all() and 0 <= crop.min() and crop.max() <= 1


def test_vto_tryon_eyeshadow_writes_the_photo_and_the_crop(astronaut, tmp_path, capsys):
    write_image(tmp_path / "face.png", astronaut)
    assert cli.run(["tryon", "eyeshadow", "--image", str(tmp_path / "face.png"), "--params", "Emerald",
                    "--out", str(tmp_path / "out.png"), "--samples", str(SAMPLES)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["size"] == [512, 512] and printed["params"]["green"] == PRESETS["Emerald"]["green"]
    assert cli.run(["tryon", "eyeshadow", "--image", str(tmp_path / "face.png"), "--params", "Emerald",
                    "--out", str(tmp_path / "crop.png"), "--crop", "--samples", str(SAMPLES)]) == 0
    assert read_image(tmp_path / "crop.png")[0].shape == (64, 64, 3)


@pytest.mark.parametrize("case, message", [
    ("no face", "no face found: the eye shadow is tried on the eyelids of a face"),
    ("lids too small", "no face found with eyelids wide enough to try on"),
    ("out of range", "parameter 'red' = 300 is outside its range"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(case, message, astronaut, tmp_path, capsys):
    image = {"no face": np.random.default_rng(0).random((200, 300, 3)).astype(np.float32),
             "lids too small": resize(astronaut, 320, 320)}.get(case, astronaut)
    write_image(tmp_path / "face.png", image)
    params = '{"red": 300}' if case == "out of range" else "Plum"
    out = tmp_path / "out.png"
    assert cli.run(["tryon", "eyeshadow", "--image", str(tmp_path / "face.png"), "--params", params,
                    "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and not out.exists()


def test_the_previews_view_shows_both_eyes_with_the_whole_photo_try_on(astronaut):
    from vto_core.photo.framing import view_cut

    from blender_addon.renderers.tryon import around

    shown, worn = tryon_view(astronaut, PRESETS["Plum"], 96, SAMPLES, 0, EYESHADOW)
    view = around([np.asarray(lid.outer, np.float64) for _, lid in find_regions(astronaut, EYESHADOW)], 96)
    whole = tryon_product(EYESHADOW, astronaut, PRESETS["Plum"], samples=SAMPLES)
    assert np.array_equal(shown, view_cut(astronaut, view, 96))
    assert np.abs(worn - view_cut(whole, view, 96)).max() < 1e-6 and np.abs(worn - shown).max() > 0.05
