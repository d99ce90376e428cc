"""The hair locator: the person model (blender_addon/models/person_segmenter.onnx) and per-photo colour models, grown
from a seed above the forehead; and the test of a picture with no face."""

from pathlib import Path

import numpy as np
import pytest

from vto_core.errors import VtoError

pytest.importorskip("onnxruntime")
from vto_core.photo import face_reader as fr  # noqa: E402
from vto_core.photo import hair_locator as hl  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
MODELS = ROOT / "blender_addon" / "models"


@pytest.fixture(scope="module")
def reader():
    return fr.cached_reader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx")


@pytest.fixture(scope="module")
def locator():
    return hl.cached_hair_locator(MODELS / "person_segmenter.onnx")


@pytest.fixture(scope="module")
def astronaut_hair():
    """The astronaut's hand-drawn hair mask (benchmarks/photos/hair_masks.json), (512, 512) bool."""
    from benchmarks.hand_masks import load_records, rasterise

    return rasterise(load_records()["package:skimage.data.astronaut"], 512, 512)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / (a | b).sum())


def test_the_astronauts_hair_is_found(reader, locator, astronaut, astronaut_hair):
    found = locator.locate(astronaut, reader.read(astronaut))
    hair = found.mask > 0.5
    assert found.mask.shape == (512, 512) and found.mask.dtype == np.float32 and found.faces == 1
    assert iou(hair, astronaut_hair) >= 0.6
    assert fr.tight_box(found.mask) == found.box
    assert not hair[200:260, 180:260].any()  # her face below the eyes: skin, never hair
    assert not hair[400:, :].any()  # her suit


def test_the_person_model_separates_person_from_backdrop(locator, astronaut):
    # The astronaut fills the middle; the model's input there must read as a person, the flag's corner as not.
    frame = np.array([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0]])  # the whole 512 px photo onto 256 px
    person = locator.person(astronaut, frame)
    assert person.shape == (256, 256) and np.isfinite(person).all()
    assert person[100:140, 100:140].mean() > 0.9 and person[:30, :20].mean() < 0.1


@pytest.mark.parametrize("case", ["bald", "hat", "out of frame"])
def test_a_head_without_hair_is_refused_in_one_line(reader, locator, astronaut, astronaut_hair, case):
    image = astronaut.copy()
    if case == "bald":
        image[astronaut_hair] = astronaut[130:150, 200:250].reshape(-1, 3).mean(0)
    elif case == "hat":
        image[astronaut_hair] = (0.75, 0.1, 0.1)
    else:
        image = astronaut[110:]  # cut at the eyebrows
    face = reader.read(image)
    assert face is not None
    with pytest.raises(VtoError, match=r"^no hair found: [^\n]+$"):
        locator.locate(image, face)


def test_a_patch_of_hair_passes_and_what_is_not_hair_does_not(astronaut, hopper):
    assert hl.patch_problem(astronaut[20:90, 150:230]) == ""  # the astronaut's hair, hand patch
    assert hl.patch_problem(hopper[155:177, 167:179]) == ""  # Grace Hopper's grey hair
    rng = np.random.default_rng(0)
    problems = {"blank": np.full((64, 64, 3), 0.5, np.float32), "noise": rng.random((64, 64, 3)),
                "orange": np.tile(np.linspace(0, 1, 64)[:, None, None], (1, 64, 3)) * (1.0, 0.45, 0.1)}
    said = {name: hl.patch_problem(image) for name, image in problems.items()}
    assert said["blank"] == "no hair found: the image is blank"
    assert said["noise"].startswith("no hair found: no face, and the image is noise")
    assert said["orange"].startswith("no hair found: no face, and the image's colour")


@pytest.mark.parametrize("lab, hair", [((30, 5, 15), True), ((80, 2, 20), True), ((15, 0.5, 1), True),
                                       ((40, 30, 15), True), ((40, 10, -30), True), ((50, 60, 40), False),
                                       ((60, 40, -10), False), ((70, 10, 40), False)])
def test_hair_colours(lab, hair):
    assert hl.is_hair_colour(np.array(lab, float)) is hair


def test_extremes_give_finite_results_or_one_line(reader, locator, astronaut):
    face = reader.read(astronaut)
    for scale in (1.3, 50.0):  # HDR values, cleaned and clipped as the face reader cleans them
        hdr = astronaut * scale
        hdr[0, 0] = np.nan
        try:
            found = locator.locate(hdr, face)
        except VtoError as exc:  # 50x is white: no hair to see
            assert scale > 2 and str(exc).startswith("no hair found: ") and "\n" not in str(exc)
        else:
            assert np.isfinite(found.mask).all() and found.mask.any()
    for image in (np.zeros((40, 40, 3)), np.ones((40, 40, 3)), np.full((40, 40, 3), np.inf)):
        assert hl.patch_problem(image) == "no hair found: the image is blank"


def test_helpers():
    seed = np.zeros((5, 5), bool)
    seed[0, 0] = True
    allowed = np.ones((5, 5), bool)
    allowed[2, :] = False
    assert hl.grow(seed, allowed).sum() == 10  # the rows above the wall only
    weights = hl.linear_weights(6, 3)
    assert np.allclose(weights.sum(1), 1) and np.allclose(weights @ np.array([0.0, 1.0, 2.0]),
                                                          [0, 0.25, 0.75, 1.25, 1.75, 2])
    model = hl.Gaussian.fit(np.random.default_rng(0).normal((50, 5, 10), 3, (200, 3)))
    assert model.log_likelihood(np.array([50.0, 5, 10])) > model.log_likelihood(np.array([80.0, 5, 10]))
    assert hl.Gaussian.fit(np.zeros((3, 3))) is None

