"""Eyelids in a whole portrait (vto_core.photo.face_regions, PhotoReader.face_region_reference): both eyes found and
framed as the default eye scene frames one (the left flipped), the light read beside the lips, and one-line refusals
for a photo with no face, eyes too small, eyes hidden, or no colour."""

from pathlib import Path

import numpy as np
import pytest
import skimage.data

from vto_core.colour import srgb_to_lab
from vto_core.errors import VtoError
from vto_core.imageio import resize
from vto_core.photo.face_regions import (MAX_WHITE_CHROMA, MIN_OPENING_CONTRAST, opening_contrast, region_width,
                                        unseen_reason, white_chroma)
from vto_core.photo.framing import region_view, view_cut
from vto_core.photo.photo_reader import PhotoReader
from vto_core.products import EYELIDS, EYESHADOW, LEFT_EYELID, LIPSTICK

MODELS = Path(__file__).resolve().parents[3] / "blender_addon" / "models"
READER = PhotoReader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx", MODELS / "person_segmenter.onnx")
ASTRONAUT = skimage.data.astronaut().astype(np.float32) / 255  # public domain (NASA): Eileen Collins


def covered(photo: np.ndarray, colour, texture: float = 0.0) -> np.ndarray:
    """`photo` with both eye openings (and the lids around them) under an ellipse of `colour` (3,) and noise of
    `texture` (sunglasses; a hand)."""
    face = READER.face_of(photo)
    out, rng = photo.copy(), np.random.default_rng(0)
    rows, cols = np.mgrid[:photo.shape[0], :photo.shape[1]]
    for region in (EYELIDS, LEFT_EYELID):
        opening = face.landmarks[list(region.opening)]
        (x, y), width = opening.mean(axis=0), np.ptp(opening[:, 0])
        inside = ((cols - x) / width) ** 2 + ((rows - y) / (0.7 * width)) ** 2 < 1
        out[inside] = np.clip(np.asarray(colour) + rng.normal(0.0, texture, (inside.sum(), 3)), 0.0, 1.0)
    return out


def test_both_eyes_are_read_the_left_flipped_as_a_right_eye():
    reference = READER.face_region_reference(EYESHADOW, ASTRONAUT)
    assert len(reference.images) == 2 and [r for r, _ in reference.regions] == [EYELIDS, LEFT_EYELID]
    (_, right), (_, left) = reference.regions
    assert right.box[0] < left.box[0]  # the subject's right eye is the photo's left
    view, size, turn = region_view(left, LEFT_EYELID)
    assert turn == 0.0 and reference.views[0].shape == (size, size, 3)
    unflipped = view_cut(ASTRONAUT, view, size, reference.light)
    np.testing.assert_allclose(reference.views[0], unflipped[:, ::-1], atol=1e-6)
    # framed as the default eye scene frames a lid: it spans EYELID_FRAME_SHARE of the square's width
    columns = np.nonzero(reference.region[1].any(axis=0))[0]
    assert abs((columns.max() + 1 - columns.min()) / reference.image.shape[1] - EYELIDS.frame_share) < 0.03
    # the light is the face's, read beside the lips: the lipstick's reading of the same photo
    np.testing.assert_allclose(reference.light.gains, READER.face_region_reference(LIPSTICK, ASTRONAUT).light.gains)
    assert all(np.isfinite(image).all() and image.min() >= 0 and image.max() <= 1 for image in reference.images)


def test_an_open_eye_shows_its_white_and_iris_a_covered_one_does_not():
    face = READER.face_of(ASTRONAUT)
    for region in (EYELIDS, LEFT_EYELID):
        assert opening_contrast(ASTRONAUT, face.landmarks, region) > 2 * MIN_OPENING_CONTRAST
        assert 20 < region_width(face.landmarks, region) < 80 and unseen_reason(ASTRONAUT, face.landmarks, region) == ""
        assert white_chroma(ASTRONAUT, face.landmarks, region) < MAX_WHITE_CHROMA / 2  # the white is greyer than skin
    assert opening_contrast(ASTRONAUT, face.landmarks, LIPSTICK.face_region) is None  # lips have no opening to judge
    assert white_chroma(ASTRONAUT, face.landmarks, LIPSTICK.face_region) is None


def test_a_bright_shade_inside_the_opening_leaves_the_eye_seen():
    """A gold lid reaching into the top of the opening (a mesh a few px off, as on a tilted photo) is brighter and far
    more chromatic than the eye's white; the white is still read, and the eye is not called hidden."""
    face = READER.face_of(ASTRONAUT)
    photo = ASTRONAUT.copy()
    for region in (EYELIDS, LEFT_EYELID):
        opening = face.landmarks[list(region.opening)]
        (x0, y0), (x1, y1) = opening.min(axis=0).astype(int), opening.max(axis=0).astype(int) + 1
        photo[y0:y0 + max(2, (y1 - y0) // 3), x0:x1] = (0.95, 0.78, 0.35)
    for region in (EYELIDS, LEFT_EYELID):
        assert white_chroma(photo, face.landmarks, region) < MAX_WHITE_CHROMA
        assert unseen_reason(photo, face.landmarks, region) == ""


def test_a_hand_the_colour_of_the_cheek_is_refused_by_the_missing_white():
    """The cheek under each eye moved over it: its texture spreads L* as an eye does, but nothing in it is as grey as an
    eye's white."""
    face = READER.face_of(ASTRONAUT)
    photo, rows, cols = ASTRONAUT.copy(), *np.mgrid[:ASTRONAUT.shape[0], :ASTRONAUT.shape[1]]
    for region in (EYELIDS, LEFT_EYELID):
        opening = face.landmarks[list(region.opening)]
        (x, y), width = opening.mean(axis=0), np.ptp(opening[:, 0])
        inside = ((cols - x) / width) ** 2 + ((rows - y) / (0.7 * width)) ** 2 < 1
        photo[inside] = ASTRONAUT[np.clip(rows + int(1.6 * width), 0, 511), cols][inside]
    with pytest.raises(VtoError, match=r"^no eyelids found: they are hidden \("):
        READER.face_region_reference(EYESHADOW, photo)


@pytest.mark.parametrize("cover, texture", [((0.06, 0.06, 0.07), 0.01), ((0.80, 0.58, 0.48), 0.02)],
                         ids=["sunglasses", "hand"])
def test_eyes_hidden_are_refused_in_one_line(cover, texture):
    with pytest.raises(VtoError, match=r"^no eyelids found: they are hidden \(the eye does not show") as error:
        READER.face_region_reference(EYESHADOW, covered(ASTRONAUT, cover, texture))
    assert "\n" not in str(error.value)


def test_one_eye_hidden_reads_the_other_and_says_so():
    face = READER.face_of(ASTRONAUT)
    photo = ASTRONAUT.copy()
    opening = face.landmarks[list(LEFT_EYELID.opening)]
    x0, y0 = (int(v) - 6 for v in opening.min(axis=0))
    x1, y1 = (int(v) + 6 for v in opening.max(axis=0))
    photo[y0:y1, x0:x1] = (0.05, 0.05, 0.06)
    reference = READER.face_region_reference(EYESHADOW, photo)
    assert [r for r, _ in reference.regions] == [EYELIDS] and reference.views == []
    assert any(note.startswith("1 of 2 eyelids not read: they are hidden") for note in reference.notes)


def test_eyes_too_small_no_face_and_no_colour_are_refused():
    small = resize(ASTRONAUT, 96, 96)  # lids ~10 px across
    with pytest.raises(VtoError, match=r"^no eyelids found: they are too small \(\d+ px across; at least 16\)"):
        READER.face_region_reference(EYESHADOW, small)
    with pytest.raises(VtoError, match=r"^no eyelids found: no face in the image"):
        READER.face_region_reference(EYESHADOW, np.full((128, 128, 3), 0.5, np.float32))
    grey = np.repeat(srgb_to_lab(ASTRONAUT)[..., :1] / 100, 3, axis=-1).astype(np.float32)
    with pytest.raises(VtoError, match=r"^a black-and-white photo has no eyeshadow colour to read"):
        READER.face_region_reference(EYESHADOW, grey)


def test_a_crop_is_read_as_the_artist_framed_it():
    """A crop is the artist's framing, as for lips: read as it is; eyes found in it give the light, a crop of one eye
    (no face in it) is read as it is with a note, its light kept."""
    face = READER.face_of(ASTRONAUT)
    x0, y0 = face.landmarks.min(axis=0).astype(int)
    x1, y1 = face.landmarks.max(axis=0).astype(int)
    on_face = READER.face_region_reference(EYESHADOW, ASTRONAUT, crop=(x0 - 20, y0 - 20, x1 - x0 + 40, y1 - y0 + 40))
    assert on_face.light is not None and on_face.light.read_from == "skin" and on_face.views == []
    lid = face.landmarks[list(EYELIDS.loops[0])]
    (lx0, ly0), (lx1, ly1) = lid.min(axis=0).astype(int) - 4, lid.max(axis=0).astype(int) + 4
    one_eye = READER.face_region_reference(EYESHADOW, ASTRONAUT, crop=(lx0, ly0, lx1 - lx0, ly1 - ly0))
    assert one_eye.views == [] and one_eye.region is None and one_eye.light is None
    assert np.array_equal(one_eye.image, ASTRONAUT[ly0:ly1, lx0:lx1])
    assert "no eyelids found in the crop: the crop is read as framed on them" in one_eye.notes
