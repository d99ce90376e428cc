"""Looks tried on real portraits (`vto dataset lipstick --photos`): training faces only, repeatable, read as Match
reads a photo, and bad folders refused."""

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.blender
pytest.importorskip("bpy")

from blender_addon.datasets.photo_looks import BLOCK, camera_view, face_index, training_faces  # noqa: E402
from vto_core import cli  # noqa: E402
from vto_core.colour import srgb_to_lab  # noqa: E402
from vto_core.dataset import DatasetReader  # noqa: E402
from vto_core.errors import VtoError  # noqa: E402
from vto_core.imageio import write_image  # noqa: E402

FACES = Path(__file__).resolve().parents[3] / "data" / "faces"
FACE = "nasa_christina_koch.jpg"  # a training face (faces.json)


def hashes(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def test_only_the_training_split_of_a_listed_folder_is_used_and_any_photo_of_an_unlisted_one(tmp_path):
    listed = json.loads((FACES / "faces.json").read_text())
    kept = {path.name for path in training_faces(FACES)}
    assert kept == {Path(e["file"]).name for e in listed if e["split"] == "train"}
    never = {Path(e["file"]).name for e in listed if e["split"] != "train"}
    assert len(never) >= 14 and not kept & never  # held-out and evaluation faces (the astronaut, Grace Hopper) out
    shutil.copy(FACES / FACE, tmp_path / "a.jpg")
    (tmp_path / "notes.txt").write_text("not a photo")
    assert [p.name for p in training_faces(tmp_path)] == ["a.jpg"]
    (tmp_path / "empty").mkdir()
    with pytest.raises(VtoError, match="no portrait to train on"):
        training_faces(tmp_path / "empty")


def test_looks_come_in_blocks_on_one_face_and_every_face_is_reached():
    assert len({face_index(1, i, 5) for i in range(BLOCK)}) == 1
    assert {face_index(1, i * BLOCK, 5) for i in range(5)} == set(range(5))
    assert camera_view(3, 7) == camera_view(3, 7) and camera_view(3, 7) != camera_view(3, 8)


def test_photo_looks_are_repeatable_and_show_the_product_on_the_lips(tmp_path):
    faces = tmp_path / "faces"
    faces.mkdir()
    shutil.copy(FACES / FACE, faces / FACE)
    argv = ["dataset", "lipstick", "--n", "3", "--seed", "4", "--samples", "4", "--photos", str(faces), "--quiet"]
    for name in ("a", "b"):
        assert cli.run([*argv, "--out", str(tmp_path / name)]) == 0
    assert hashes(tmp_path / "a") == hashes(tmp_path / "b")
    reader = DatasetReader(tmp_path / "a")
    manifest = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert list(manifest["photos"]) == [FACE] and "lighting" not in manifest
    moved = []
    for position in range(3):
        sample = reader[position]
        assert sample.record["face"] == FACE and sample.render.shape == sample.source.shape == (64, 64, 3)
        assert np.isfinite(sample.render).all()
        moved.append(np.abs(srgb_to_lab(sample.render) - srgb_to_lab(sample.source)).max(axis=-1))
        changed = moved[-1] > 2.0
        assert changed.any() and changed.mean() < 0.3  # the lips, not the whole frame
        assert not changed[:6].any()  # the top rows (nose and upper lip's skin) are the photo's


@pytest.mark.parametrize("extra, message", [
    (["--sensitivity"], "not with --blend, --lighting, --sensitivity or --masks"),
    (["--lighting", "wide"], "not with --blend, --lighting, --sensitivity or --masks"),
])
def test_photos_with_options_of_the_default_scene_are_refused(tmp_path, capsys, extra, message):
    out = tmp_path / "bad"
    assert cli.run(["dataset", "lipstick", "--out", str(out), "--n", "2", "--photos", str(FACES), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and not out.exists()


def test_a_folder_without_a_face_to_try_on_is_a_clear_error(tmp_path, capsys):
    blank = tmp_path / "blank"
    blank.mkdir()
    write_image(blank / "wall.png", np.full((200, 200, 3), 0.6, np.float32))
    assert cli.run(["dataset", "lipstick", "--out", str(tmp_path / "ds"), "--n", "1", "--samples", "2",
                    "--photos", str(blank)]) == 2
    assert "no lips can be tried on any of the 1 portraits" in capsys.readouterr().err
    assert not list((tmp_path / "ds" / "samples").glob("*"))


def test_eye_shadow_looks_take_each_eye_by_turns_read_as_a_right_eye(tmp_path):
    """`vto dataset eyeshadow --photos`: looks on the right and left lids by turns, each read as Match reads one eye
    (the left flipped), repeatable; the shade lies on the lid, not on the brow or the cheek."""
    from blender_addon.datasets.photo_looks import FRAME_RENDER, PhotoLooks
    from vto_core.products import EYESHADOW

    faces = tmp_path / "faces"
    faces.mkdir()
    shutil.copy(FACES / FACE, faces / FACE)
    argv = ["dataset", "eyeshadow", "--n", "2", "--seed", "4", "--samples", "4", "--photos", str(faces), "--quiet"]
    for name in ("a", "b"):
        assert cli.run([*argv, "--out", str(tmp_path / name)]) == 0
    assert hashes(tmp_path / "a") == hashes(tmp_path / "b")
    reader = DatasetReader(tmp_path / "a")
    assert [reader[k].record["region"] for k in range(2)] == [0, 1]  # the right eye, then the left
    for position in range(2):
        sample = reader[position]
        moved = np.abs(srgb_to_lab(sample.render) - srgb_to_lab(sample.source)).max(axis=-1)
        changed = moved > 2.0
        assert changed.any() and changed.mean() < 0.4 and not changed[-8:].any()  # the lid, not the cheek below
    looks = PhotoLooks(faces, 64, 4, 4, EYESHADOW)
    _, targets, _ = looks.face(0)
    assert [t.region.mirrored for t in targets] == [False, True] and all(t.n == FRAME_RENDER for t in targets)
