"""The lipstick on a photo (blender_addon.renderers.tryon, `vto tryon`): the node group rendered onto a real
portrait's lips, the rest of the photo untouched."""

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("bpy")
pytestmark = pytest.mark.blender

from blender_addon.renderers.tryon import find_lips, tryon_lipstick  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.colour import srgb_to_lab  # noqa: E402
from vto_core.imageio import read_image, resize, write_image  # noqa: E402
from vto_core.photo.framing import region_view, view_cut  # noqa: E402
from vto_core.photo.tryon import feathered  # noqa: E402
from vto_core.presets import load_presets  # noqa: E402
from vto_core.products import LIPS, LIPSTICK  # noqa: E402

PHOTOS = Path(__file__).resolve().parents[3] / "benchmarks" / "photos"
PRESETS = load_presets("lipstick")
SAMPLES = 8


@pytest.fixture(scope="module")
def astronaut():
    import skimage.data

    return skimage.data.astronaut().astype(np.float32) / 255


def faces():
    """name -> portrait: a smile with teeth, a closed mouth, a moustache, a face turned (tilted) 20 degrees."""
    import matplotlib.cbook
    import skimage.data

    from benchmarks.common import tilted

    astronaut = skimage.data.astronaut().astype(np.float32) / 255
    return {"teeth": astronaut,
            "closed": read_image(matplotlib.cbook.get_sample_data("grace_hopper.jpg", asfileobj=False))[0],
            "moustache": read_image(PHOTOS / "nasa_jose_hernandez.jpg")[0],
            "turned": tilted(astronaut, 20)}


@pytest.mark.parametrize("name", ["teeth", "closed", "moustache", "turned"])
def test_each_face_gets_a_clean_render_on_its_lips_and_nowhere_else(name):
    photo = faces()[name]
    lips = find_lips(photo, LIPSTICK)
    worn = tryon_lipstick(photo, PRESETS["Classic Red"], samples=SAMPLES)
    reach = feathered(lips.mask) > 0
    assert np.isfinite(worn).all() and worn.shape == photo.shape
    assert np.array_equal(worn[~reach], photo[~reach])  # off the lips: the photo, every pixel
    inside = lips.mask > 0.5
    lab_worn, lab_photo = srgb_to_lab(worn[inside].mean(0)), srgb_to_lab(photo[inside].mean(0))
    assert lab_worn[1] > lab_photo[1] + 3 and lab_worn[0] < lab_photo[0]  # redder and darker: the red is on them
    mouth = np.zeros(photo.shape[:2], bool)  # the teeth and the mouth's inside, two pixels from the lips
    from vto_core.photo.face_reader import polygon_mask
    mouth[:] = polygon_mask(np.asarray(lips.inner), 0, 0, photo.shape[1], photo.shape[0])
    mouth &= ~(feathered(feathered(lips.mask.astype(np.float32)) > 0) > 0)
    assert np.array_equal(worn[mouth], photo[mouth])


def test_the_crop_is_the_frame_match_reads_with_the_product_on_it(astronaut):
    lips = find_lips(astronaut, LIPSTICK)
    view, size, _ = region_view(lips, LIPS)
    crop = tryon_lipstick(astronaut, PRESETS["Espresso"], crop=64, samples=SAMPLES)
    scaled = view.copy()
    scaled[:, :2] *= size / 64
    frame = view_cut(astronaut, scaled, 64)
    changed = np.abs(crop - frame).max(axis=-1) > 1 / 255
    assert crop.shape == (64, 64, 3) and 0.03 < changed.mean() < 0.4  # the lips, not the frame
    assert srgb_to_lab(crop[changed].mean(0))[0] < srgb_to_lab(frame[changed].mean(0))[0] - 10  # espresso is dark


def test_lightness_follows_the_products_and_a_red_is_redder_than_a_nude(astronaut):
    inside = find_lips(astronaut, LIPSTICK).mask > 0.5
    lab = {name: srgb_to_lab(tryon_lipstick(astronaut, PRESETS[name], samples=SAMPLES)[inside].mean(0))
           for name in ("Espresso", "Classic Red", "Bare Nude")}
    assert lab["Espresso"][0] < lab["Classic Red"][0] < lab["Bare Nude"][0]
    hue = {name: np.degrees(np.arctan2(value[2], value[1])) for name, value in lab.items()}
    assert lab["Classic Red"][1] > lab["Bare Nude"][1] and hue["Classic Red"] < hue["Bare Nude"]


def test_vto_tryon_writes_the_whole_photo_repeatably(astronaut, tmp_path, capsys):
    write_image(tmp_path / "face.png", astronaut)
    outs = [tmp_path / f"out{i}.png" for i in range(2)]
    for out in outs:
        assert cli.run(["tryon", "lipstick", "--image", str(tmp_path / "face.png"), "--params", "Classic Red",
                        "--out", str(out), "--seed", "7", "--samples", str(SAMPLES)]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["size"] == [512, 512] and printed["params"]["red"] == 190
    assert outs[0].read_bytes() == outs[1].read_bytes()
    assert cli.run(["tryon", "lipstick", "--image", str(tmp_path / "face.png"), "--params", "preset:Espresso",
                    "--out", str(tmp_path / "crop.png"), "--crop", "--samples", str(SAMPLES)]) == 0
    assert read_image(tmp_path / "crop.png")[0].shape == (64, 64, 3)


@pytest.mark.parametrize("case, message", [
    ("no face", "no face found"),
    ("lips too small", "no face found with lips wide enough"),
    ("out of range", "parameter 'red' = 300 is outside its range"),
    ("another renderer", "unknown lipstick parameter 'brightness'"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(case, message, astronaut, tmp_path, capsys):
    image = {"no face": np.random.default_rng(0).random((200, 300, 3)).astype(np.float32),
             "lips too small": resize(astronaut, 256, 256)}.get(case, astronaut)
    write_image(tmp_path / "face.png", image)
    params = {"out of range": '{"red": 300}', "another renderer": '{"brightness": 0.1}'}.get(case, "Classic Red")
    out = tmp_path / "out.png"
    assert cli.run(["tryon", "lipstick", "--image", str(tmp_path / "face.png"), "--params", params,
                    "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and not out.exists()


def test_in_place_draws_on_the_photo_itself_as_the_copy_would(astronaut):
    copied = tryon_lipstick(astronaut, PRESETS["Classic Red"], samples=SAMPLES)
    mine = astronaut.copy()
    drawn = tryon_lipstick(mine, PRESETS["Classic Red"], samples=SAMPLES, in_place=True)
    assert drawn is mine and np.array_equal(drawn, copied) and not np.array_equal(drawn, astronaut)


def test_the_previews_view_is_the_whole_photo_try_on_framed_around_the_lips(astronaut):
    """tryon_view draws on the part of the photo it shows: the pixels of the whole photo tried on, then cut."""
    from blender_addon.renderers.tryon import around_region, tryon_view

    shown, worn = tryon_view(astronaut, PRESETS["Classic Red"], 96, SAMPLES, 0, LIPSTICK)
    view = around_region(find_lips(astronaut, LIPSTICK), 96)
    whole = tryon_lipstick(astronaut, PRESETS["Classic Red"], samples=SAMPLES)
    assert np.array_equal(shown, view_cut(astronaut, view, 96))
    assert np.abs(worn - view_cut(whole, view, 96)).max() < 1e-6 and np.abs(worn - shown).max() > 0.05
