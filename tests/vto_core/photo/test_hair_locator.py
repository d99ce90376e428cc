"""The hair locator: the person model (blender_addon/models/person_segmenter.onnx) and per-photo colour models, grown
from seeds above the forehead, over it and beside the face; and the test of a picture with no face."""

import dataclasses
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


TIGHT = (slice(75, 300), slice(130, 330))  # the astronaut framed as a beauty photo: her forehead's top out of frame


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


def test_a_tight_crop_is_found_beside_the_face(reader, locator, astronaut, astronaut_hair):
    crop = np.ascontiguousarray(astronaut[TIGHT])
    face = reader.read(crop)
    frame = hl.HeadFrame(face.landmarks, *crop.shape[:2])
    assert not (frame.seed() & frame.inside).any()  # the band above her forehead is out of frame
    hair = locator.locate(crop, face).mask > 0.5
    assert iou(hair, astronaut_hair[TIGHT]) >= 0.5
    assert hair[:, :40].any() and hair[:, 150:].any()  # beside her face on both sides
    assert not hair[40:95, 65:125].any()  # her face below the eyes


def tight_crop_of(reader, name: str) -> tuple[np.ndarray, np.ndarray]:
    """A public portrait of benchmarks/photos cut as a beauty photo (bench_hair_found.tight_crop: eyebrows to chin,
    1.6 face widths), and its hand-drawn hair mask cut alike."""
    import json

    from benchmarks.bench_hair_found import tight_crop
    from benchmarks.bench_real_photos import PHOTOS, load_photo
    from benchmarks.hand_masks import load_records, rasterise

    record = next(r for r in json.loads(PHOTOS.read_text()) if r["file"] == name)
    photo = load_photo(record, PHOTOS.parent)
    x0, y0, x1, y1 = tight_crop(reader.read(photo), *photo.shape[:2])
    drawn = rasterise(load_records()[name], *photo.shape[:2])
    return np.ascontiguousarray(photo[y0:y1, x0:x1]), drawn[y0:y1, x0:x1]


def test_a_tight_crop_is_shown_to_the_person_model_zoomed_out_as_well(reader, locator, monkeypatch):
    # Susan Helms' dark curls fill both sides of her crop; shown the crop alone, the person model takes those on the
    # left for the dark backdrop.
    crop, drawn = tight_crop_of(reader, "nasa_susan_helms.jpg")
    face = reader.read(crop)
    assert hl.HeadFrame(face.landmarks, *crop.shape[:2]).share_in_photo() < hl.CROP_SHARE
    hair = locator.locate(crop, face).mask > 0.5
    width = crop.shape[1]
    assert iou(hair, drawn) >= 0.5 and hair[:, :width // 5].mean() > 0.3 and hair[:, -width // 5:].mean() > 0.3
    monkeypatch.setattr(hl, "CROP_SHARE", 0.0)  # the crop shown once
    assert iou(locator.locate(crop, face).mask > 0.5, drawn) < 0.4


def test_hair_starts_only_where_the_crop_alone_shows_the_person(reader, locator):
    # The ISS crew photo cut around one face: a beige wall at the crop's left edge, which the zoomed-out view takes
    # for a body. Seeded there, the wall would be read as hair; the short hair at his temples is too little to read.
    crop, _ = tight_crop_of(reader, "nasa_iss_expedition1_crew.jpg")
    with pytest.raises(VtoError, match="^no hair found"):
        locator.locate(crop, reader.read(crop))


@pytest.mark.parametrize("case", ["bald", "hat", "hat of two colours", "out of frame", "out of frame on every side",
                                  "bald crop", "hat crop"])
def test_a_head_without_hair_is_refused_in_one_line(reader, locator, astronaut, astronaut_hair, case):
    image = astronaut.copy()
    skin = astronaut[130:150, 200:250].reshape(-1, 3).mean(0)
    if case.startswith("bald"):
        image[astronaut_hair] = skin
    elif case == "hat of two colours":  # a cap, each part a hair colour: a black band, a white crown; no hair below
        forehead, chin = reader.read(astronaut).landmarks[[hl.FOREHEAD, hl.CHIN], 1]
        rows = np.arange(512)[:, None]
        band = rows >= forehead - 0.29 * (chin - forehead)  # up to the middle of the band where hair is looked for
        image[astronaut_hair & ~band], image[astronaut_hair & band] = 0.92, 0.06
        image[astronaut_hair & (rows >= forehead)] = skin
    elif case.startswith("hat"):
        image[astronaut_hair] = (0.75, 0.1, 0.1)
    elif case == "out of frame":
        image = astronaut[110:]  # cut at the eyebrows
    else:
        image = astronaut[100:300, 185:265]  # her face from the eyes down, cut inside her cheeks: no hair on any side
    image = np.ascontiguousarray(image[TIGHT] if case.endswith("crop") else image)
    face = reader.read(image)
    assert face is not None
    with pytest.raises(VtoError, match=r"^no hair found: [^\n]+$") as refused:
        locator.locate(image, face)
    assert case != "hat of two colours" or "two colours far apart" in str(refused.value)


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
    for y, x, side in ((120, 200, 16), (0, 0, 8)):  # tiny crops of her cheek and of the flag, her face read whole
        shifted = dataclasses.replace(face, landmarks=face.landmarks - np.array([x, y], np.float32))
        with pytest.raises(VtoError, match=r"^no hair found: [^\n]+$"):
            locator.locate(astronaut[y:y + side, x:x + side], shifted)


def test_the_seeds_lie_where_hair_starts(reader, astronaut):
    face = reader.read(astronaut)
    frame = hl.HeadFrame(face.landmarks, 512, 512)
    oval = frame.polygon(face.landmarks[hl.FACE_OVAL])
    left, right = frame.beside()
    for strip in (left, right):  # whole inside the photo: as large as the strip's own area, outside the oval
        assert strip.sum() == pytest.approx(frame.beside_area(), rel=0.15) and not (strip & oval).any()
    assert frame.along_right[left].max() < -0.4 < 0.4 < frame.along_right[right].min()  # the jaw narrows
    eyes, mouth = frame.eyes_and_mouth()
    assert 0.1 < eyes < 0.3 and -0.3 < mouth < -0.1 and 0.25 < eyes - mouth < 0.5  # face heights above the centre
    fringe = frame.above_brows() & oval
    assert fringe.sum() == pytest.approx(frame.fringe_area(), rel=0.15)
    assert frame.along_up[fringe].min() > eyes
    edges = frame.oval_edges(np.array([0.0]))
    assert -0.6 < edges[0][0] < -0.4 and 0.4 < edges[1][0] < 0.6  # the cheeks: half a face width out


def test_every_seed_that_shows_hair_grows_and_one_of_another_colour_does_not():
    rng = np.random.default_rng(0)
    lab = np.empty((40, 40, 3))
    lab[:20] = rng.normal((30, 8, 15), 2, (20, 40, 3))  # brown hair above and on the left
    lab[20:, 20:] = rng.normal((12, 0, -20), 2, (20, 20, 3))  # a navy headset on the right
    lab[20:, :20] = rng.normal((30, 8, 15), 2, (20, 20, 3))
    rows = np.arange(40)[:, None] + np.zeros((1, 40), int)
    cols = rows.T
    top, left, right = (rows < 10) & (cols < 20), (rows >= 20) & (cols < 10), (rows >= 20) & (cols >= 30)
    models = {"skin": hl.Gaussian.fit(rng.normal((65, 15, 20), 3, (200, 3))),
              "background": hl.Gaussian.fit(rng.normal((10, 0, -22), 3, (200, 3)))}
    seeds = [hl.Seed("top", top, 200), hl.Seed("fringe", np.zeros_like(top), 100), hl.Seed("left", left, 200),
             hl.Seed("right", right, 200)]
    fit, grow_from, fringe = hl.hair_seeds(lab, seeds, models)
    assert np.array_equal(fit, top) and np.array_equal(grow_from, top | left) and not fringe.any()
    fit, grow_from, _ = hl.hair_seeds(lab, [hl.Seed("top", top & False, 200)] + seeds[1:], models)
    assert np.array_equal(fit, left | right) and np.array_equal(grow_from, left | right)  # no band: each side alone
    with pytest.raises(VtoError, match="^no hair found: the top of the head is out of frame"):
        hl.hair_seeds(lab, [hl.Seed(seed.name, seed.where, 1000) for seed in seeds], models)  # too little in frame


@pytest.mark.parametrize("dark, light, hat", [(10, 80, True), (30, 60, False), (5, 5, False)])
def test_a_band_above_the_forehead_of_two_lightnesses_far_apart_is_a_hat(dark, light, hat):
    lab = np.zeros((100, 3))
    lab[:50, 0], lab[50:, 0] = dark, light  # half a cap's black band, half its crown (or hair in shade and light)
    said = hl.seed_problem(lab, 100, {}, top=True)
    assert ("two colours far apart" in said) == hat
    assert hl.seed_problem(lab, 100, {}) == ""  # beside the face, hair and the backdrop mix: no such test


def test_helpers():
    seed = np.zeros((5, 5), bool)
    seed[0, 0] = True
    allowed = np.ones((5, 5), bool)
    allowed[2, :] = False
    assert hl.grow(seed, allowed).sum() == 10  # the rows above the wall only
    centres = np.arange(6) * 0.5 + 0.25  # 6 pixels over the 3 of a row, edges repeated
    assert np.allclose(hl.linear_resize(np.array([[0.0, 1.0, 2.0]]), np.array([0.5, 0.5]), centres),
                       [[0, 0.25, 0.75, 1.25, 1.75, 2]] * 2)
    assert np.allclose(hl.linear_resize(np.array([[0.0], [4.0]]), np.array([0.25, 0.75, 1.25, 1.75]),
                                        np.array([0.5]))[:, 0], [0, 1, 3, 4])
    assert hl.on_grid(np.array([-0.5, 0.5, 1.5, 2.5, 3.5]), 3) == (1, 4)
    model = hl.Gaussian.fit(np.random.default_rng(0).normal((50, 5, 10), 3, (200, 3)))
    assert model.log_likelihood(np.array([50.0, 5, 10])) > model.log_likelihood(np.array([80.0, 5, 10]))
    assert hl.Gaussian.fit(np.zeros((3, 3))) is None



def test_growing_finds_what_a_flood_fill_finds():
    from collections import deque

    rng = np.random.default_rng(5)
    for _ in range(20):
        allowed = rng.random((23, 31)) < 0.6
        seed = rng.random((23, 31)) < 0.01
        expected, queue = np.zeros_like(allowed), deque(zip(*np.nonzero(seed & allowed)))
        for row, col in queue:
            expected[row, col] = True
        while queue:
            row, col = queue.popleft()
            for r, c in ((row - 1, col), (row + 1, col), (row, col - 1), (row, col + 1)):
                if 0 <= r < 23 and 0 <= c < 31 and allowed[r, c] and not expected[r, c]:
                    expected[r, c] = True
                    queue.append((r, c))
        assert np.array_equal(hl.grow(seed, allowed), expected)


@pytest.mark.parametrize("degrees", [30, 180])
def test_the_work_grid_turns_with_the_head(reader, astronaut, degrees):
    # A tilted head's grid lies along the face's axes: the same work pixel is the same place on the head at any roll,
    # and the region drawn back onto the photo is the region's own rectangle. An upright head's grid lies along the
    # photo's axes.
    landmarks = reader.read(astronaut).landmarks.astype(np.float64)
    upright = hl.HeadFrame(landmarks, 512, 512)
    assert upright.turn == 0 and np.ptp(upright.xs[:, 0]) == 0 and np.ptp(upright.ys[0]) == 0

    def rotation(degrees):
        turn = np.radians(degrees)
        return np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])

    first = (landmarks - 256) @ rotation(20).T + 600
    second = (first - 600) @ rotation(degrees).T + 600
    base, frame = hl.HeadFrame(first, 1200, 1200), hl.HeadFrame(second, 1200, 1200)
    assert (frame.rows, frame.cols) == (base.rows, base.cols) and frame.inside.all()
    expected = (np.stack([base.xs, base.ys], -1) - 600) @ rotation(degrees).T + 600
    assert np.abs(np.stack([frame.xs, frame.ys], -1) - expected).max() < 1e-6
    assert np.abs(frame.to_work(np.stack([frame.xs, frame.ys], -1))
                  - np.stack(np.meshgrid(np.arange(frame.cols), np.arange(frame.rows)), -1) - 0.5).max() < 1e-6
    area = (1 + hl.REGION_UP + hl.REGION_DOWN) * frame.face_height * 2 * hl.REGION_SIDE * frame.face_width
    assert frame.to_image(np.ones((frame.rows, frame.cols))).sum() == pytest.approx(area, rel=0.01)
    half = frame.to_image((frame.along_right > 0).astype(float))  # the head's right half: image right when upright
    centre = frame.centre + frame.right * frame.face_width * 0.8
    assert half[int(centre[1]), int(centre[0])] == 1


def test_an_upright_grid_is_drawn_back_by_rows_and_columns_as_a_turned_one_is_pixel_by_pixel(reader, astronaut):
    frame = hl.HeadFrame(reader.read(astronaut).landmarks, 512, 512)
    # A smooth score that crosses 0.5 all over the region: its edges everywhere.
    score = (0.5 + 0.5 * np.sin(frame.along_right * 7) * np.cos(frame.along_up * 5)).astype(np.float32)
    by_axes = frame.to_image(score)
    rows, cols = np.nonzero(by_axes)
    work_rows, work_cols = ((rows + 0.5 - frame.low[1]) * frame.scale).astype(int), \
        ((cols + 0.5 - frame.low[0]) * frame.scale).astype(int)
    assert (score[work_rows, work_cols] > 0.2).all()  # each pixel drawn lies on or beside a cell that scores
    frame.turn = 1e-12  # the same grid, drawn back through the tilted head's path (its nearest of a 4x finer grid)
    by_pixels = frame.to_image(score)
    assert by_axes.sum() > 10000 and abs(by_axes.sum() / by_pixels.sum() - 1) < 0.005
    assert (by_axes != by_pixels).sum() < 0.03 * by_axes.sum()  # at the edges, by a fraction of a work pixel


def test_only_the_cells_that_score_are_drawn_back_and_the_rest_of_the_region_is_left_as_it_was(reader, astronaut):
    """to_image works near the score's non-zero cells only: a blob is drawn exactly as when every cell scores a
    little (the whole region worked on), through the upright and the tilted path alike."""
    frame = hl.HeadFrame(reader.read(astronaut).landmarks, 512, 512)
    blob = np.zeros((frame.rows, frame.cols), np.float32)
    blob[5:12, frame.cols - 9:frame.cols - 2] = 1.0  # near a corner of the region, sharp: its edge cells count
    for turn in (0.0, 1e-12):
        frame.turn = turn
        drawn, everywhere = frame.to_image(blob), frame.to_image(blob + np.float32(1e-6))
        assert drawn.sum() > 100 and np.array_equal(drawn, everywhere)
    assert not frame.to_image(np.zeros_like(blob)).any()


def test_a_canvas_black_border_is_padding_and_black_in_the_scene_is_not():
    rgb = np.full((20, 30, 3), 0.4, np.float32)
    rgb[:6, :8] = 0.0  # a turned photo's black corner, at the grid's edge
    rgb[10:14, 12:16] = 0.0  # a black thing in the middle of the scene
    rgb[15:, 25:] = 1.5 / 255  # near-black at the edge: a dark scene, not a canvas
    inside = np.ones((20, 30), bool)
    inside[:, :2] = False  # beyond the photo's left edge
    found = hl.padding(rgb, inside)
    assert found[:6, 2:8].all() and found.sum() == 6 * 6
    inside[:, :] = True
    assert hl.padding(rgb, inside)[:6, :8].all() and not hl.padding(rgb, inside)[10:14, 12:16].any()
