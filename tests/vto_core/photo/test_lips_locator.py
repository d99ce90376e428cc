"""The lips locator: BlazeFace + face mesh on onnxruntime (blender_addon/models/face_*.onnx), and the close-up test."""

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from vto_core.errors import VtoError

pytest.importorskip("onnxruntime")
from vto_core.photo import face_reader as fr  # noqa: E402
from vto_core.photo import lips_locator as ll  # noqa: E402
from vto_core.photo.face_reader import polygon_mask  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
MODELS = ROOT / "blender_addon" / "models"
DETECTOR, MESH = MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx"
# Hand-drawn tight lips boxes (x, y, w, h), as in benchmarks/photos/photos.json. The astronaut's mouth crop
# [117:173, 196:252] is a square around the mouth with skin; her lips span x 201-249, y 137-157 inside it.
ASTRONAUT_LIPS = (201, 137, 48, 20)
ASTRONAUT_MOUTH_CROP = (slice(117, 173), slice(196, 252))
HOPPER_LIPS = (226, 268, 80, 22)
HOPPER_MOUTH_CROP = (slice(228, 330), slice(215, 317))  # a square the lips span 0.78 of


def iou(a, b) -> float:
    """Intersection over union of two (x, y, w, h) boxes."""
    width = max(0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    height = max(0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    return width * height / (a[2] * a[3] + b[2] * b[3] - width * height)


@pytest.fixture(scope="module")
def locator():
    return ll.cached_locator(DETECTOR, MESH)


def resized(image: np.ndarray, scale: float) -> np.ndarray:
    """(H, W, 3) float in [0, 1] scaled by `scale` (PIL bilinear)."""
    from PIL import Image

    height, width = image.shape[:2]
    picture = Image.fromarray((image * 255).round().astype(np.uint8))
    return np.asarray(picture.resize((round(width * scale), round(height * scale)), Image.BILINEAR), np.float32) / 255


def test_the_astronauts_lips(locator, astronaut):
    found = locator.locate(astronaut)
    assert found.how == "face" and found.faces == 1 and found.note == "" and found.score > 0.99
    assert iou(found.box, ASTRONAUT_LIPS) >= 0.6
    x, y, w, h = found.box
    rows, cols = ASTRONAUT_MOUTH_CROP
    assert cols.start <= x and x + w <= cols.stop and rows.start <= y and y + h <= rows.stop
    assert found.mask.shape == (512, 512) and found.mask.dtype == np.float32
    assert set(np.unique(found.mask)) == {0.0, 1.0}
    assert fr.tight_box(found.mask) == found.box
    assert found.outer.shape == (20, 2) and found.inner.shape == (20, 2) and found.landmarks.shape == (468, 2)


def test_grace_hoppers_lips(locator, hopper):
    found = locator.locate(hopper)
    assert found.how == "face" and found.faces == 1
    assert iou(found.box, HOPPER_LIPS) >= 0.6


def test_the_mouth_opening_is_not_lips(locator, astronaut):
    # She smiles with her teeth showing: the inner contour encloses them, and the mask leaves them out.
    found = locator.locate(astronaut)
    x, y, w, h = found.box
    opening = polygon_mask(found.inner, x, y, w, h)
    assert opening.sum() > 100
    assert not found.mask[y:y + h, x:x + w][opening].any()
    lips = polygon_mask(found.outer, x, y, w, h) & ~opening
    assert found.mask[y:y + h, x:x + w].sum() == lips.sum() > 200


def test_two_faces_the_larger_is_used(locator, astronaut):
    head = astronaut[40:300, 120:360]
    big, small = resized(head, 1.5), resized(head, 1.0)
    canvas = np.full((420, 640, 3), 0.5, np.float32)
    canvas[10:10 + big.shape[0], 10:10 + big.shape[1]] = big
    canvas[60:60 + small.shape[0], 380:380 + small.shape[1]] = small
    found = locator.locate(canvas)
    assert found.faces == 2 and "2 faces" in found.note and "largest" in found.note
    expected = (10 + (201 - 120) * 1.5, 10 + (137 - 40) * 1.5, 48 * 1.5, 20 * 1.5)
    assert iou(found.box, expected) >= 0.6


@pytest.mark.parametrize("degrees", [25, 60])
def test_a_turned_portrait(locator, astronaut, degrees):
    from PIL import Image

    upright = locator.locate(astronaut)
    picture = Image.fromarray((astronaut * 255).round().astype(np.uint8))
    turned = np.asarray(picture.rotate(degrees, resample=Image.BILINEAR, expand=True, fillcolor=(90, 90, 90)),
                        np.float32) / 255
    found = locator.locate(turned)
    # PIL turns counter-clockwise about the centre and grows the canvas: where her lip points go.
    angle = np.radians(degrees)
    offset = upright.outer - 256
    expected = np.stack([np.cos(angle) * offset[:, 0] + np.sin(angle) * offset[:, 1],
                         -np.sin(angle) * offset[:, 0] + np.cos(angle) * offset[:, 1]], 1)
    expected += np.array(turned.shape[1::-1]) / 2
    distances = np.linalg.norm(found.outer - expected, axis=1)
    assert np.median(distances) < 3.0 and distances.max() < 9.0


@pytest.mark.parametrize("crop", ["astronaut", "astronaut x4", "hopper"])
def test_a_mouth_close_up_is_taken_whole(locator, astronaut, hopper, crop):
    image = {"astronaut": astronaut[ASTRONAUT_MOUTH_CROP], "astronaut x4": resized(astronaut[ASTRONAUT_MOUTH_CROP], 4),
             "hopper": hopper[HOPPER_MOUTH_CROP]}[crop]
    found = locator.locate(image)
    assert found.how == "close-up" and found.faces == 0 and "whole image" in found.note
    assert found.box == (0, 0, image.shape[1], image.shape[0])  # the whole image is read
    # the lips are the lens the test matched: central, wider than high, mostly the photo's redder pixels
    rows, cols = np.nonzero(found.mask)
    assert 0.04 < found.mask.mean() < 0.7 and cols.ptp() > rows.ptp()  # Hopper's thin lips: 6 %
    assert abs(cols.mean() / image.shape[1] - 0.5) < 0.15 and abs(rows.mean() / image.shape[0] - 0.5) < 0.25
    assert found.outer.shape[1] == 2 and len(found.outer) > 8 and found.inner.shape == (0, 2)
    assert 0.4 < found.score <= 1.0


def _not_lips() -> dict[str, np.ndarray]:
    from skimage import data

    rng = np.random.default_rng(3)
    ramp = np.linspace(0, 1, 96, dtype=np.float32)
    return {
        "uniform noise": rng.random((64, 64, 3), dtype=np.float32),
        "gaussian noise": np.clip(rng.normal(0.5, 0.15, (80, 120, 3)), 0, 1).astype(np.float32),
        "black": np.zeros((64, 64, 3), np.float32),
        "white": np.ones((64, 64, 3), np.float32),
        "grey": np.full((64, 64, 3), 0.5, np.float32),
        "skin": np.full((64, 64, 3), (0.88, 0.67, 0.59), np.float32),
        "colour ramp": np.stack(np.broadcast_arrays(ramp[None, :], ramp[:, None], np.float32(0.5)), -1),
        "coffee": data.coffee().astype(np.float32) / 255,  # a red cup on wood: a lips-like blob on skin-like colour
        "chelsea": data.chelsea().astype(np.float32) / 255,  # a cat's face (the mesh scores it 0.55)
        "rocket": data.rocket().astype(np.float32) / 255,  # a landscape
        "astronaut's eyes": data.astronaut()[70:120, 170:270].astype(np.float32) / 255,
    }


@pytest.mark.parametrize("name", list(_not_lips()))
def test_what_is_not_lips_is_refused_in_one_line(locator, name):
    with pytest.raises(VtoError, match=r"^no lips found") as caught:
        locator.locate(_not_lips()[name])
    assert "\n" not in str(caught.value)


def test_hdr_nan_and_integer_inputs(locator, astronaut):
    reference = locator.locate(astronaut)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hdr = astronaut * 1.3  # HDR: clipped to [0, 1], the face stays
        hdr[:30, -30:] = 1e30
        bright = locator.locate(hdr)
        assert bright.how == "face" and iou(bright.box, reference.box) > 0.8 and np.isfinite(bright.outer).all()
        holed = astronaut.copy()
        holed[:40, :40] = np.nan
        holed[-40:, -40:] = np.inf
        found = locator.locate(holed)
        assert found.how == "face" and iou(found.box, reference.box) > 0.8 and np.isfinite(found.mask).all()
        assert locator.locate((astronaut * 255).round().astype(np.uint8)).box == reference.box
        with pytest.raises(VtoError, match=r"^no lips found"):
            locator.locate(np.full((64, 64, 3), np.nan, np.float32))


@pytest.mark.parametrize("shape", [(8, 8, 3), (1, 1, 3), (3, 3000, 3), (3000, 2, 3), (17, 16, 3), (40, 30)])
def test_tiny_and_extreme_images_give_the_one_line_error(locator, shape):
    image = np.random.default_rng(0).random(shape, dtype=np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(VtoError, match=r"^no lips found"):
            locator.locate(image)


def test_a_bad_shape_is_refused(locator):
    with pytest.raises(VtoError, match="expected an"):
        locator.locate(np.zeros((4, 4, 2), np.float32))
    with pytest.raises(VtoError, match="expected an"):
        locator.locate(np.zeros((0, 4, 3), np.float32))


def test_the_face_lips_and_hair_modules_import_nothing_blender_lacks():
    code = ("import sys, vto_core.photo.lips_locator, vto_core.photo.face_reader, vto_core.photo.hair_locator\n"
            "bad = [m for m in ('onnxruntime', 'bpy', 'torch', 'skimage', 'scipy', 'cv2', 'PIL', 'OpenImageIO')"
            " if m in sys.modules]\nprint(','.join(bad))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0 and done.stdout.strip() == "", done.stdout + done.stderr[-500:]


def test_a_closed_mouths_lips_are_whole(locator):
    # London Set 070 (neutral, mouth closed): the face mesh leaves a band between its inner contours (10 % of the
    # lips); the locator closes it, so the mask and the try-on's mesh hold the whole lips.
    from vto_core.imageio import read_image

    photo = read_image(ROOT / "data" / "faces" / "london" / "london_070_neutral.jpg")[0][..., :3]
    found = locator.locate(photo)
    inner = found.inner
    for below, above in ll.FACING:
        assert np.allclose(inner[below], inner[above])
    assert np.allclose(found.landmarks[ll.LIP_INNER], inner)
    x, y, w, h = found.box
    whole = polygon_mask(found.outer, x, y, w, h)
    assert abs(found.mask[y:y + h, x:x + w].sum() - whole.sum()) <= 0.02 * whole.sum()
    raw = fr.cached_reader(DETECTOR, MESH).read(photo).landmarks[ll.LIP_INNER]
    assert polygon_mask(raw, x, y, w, h).sum() > 0.05 * whole.sum()  # the band that the mesh left


def lips_box(inner_colour) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 40 x 40 image of lips (display 0.6, 0.3, 0.3) whose inner contour (a 20 x 6 box) shows `inner_colour`."""
    image = np.full((40, 40, 3), (0.6, 0.3, 0.3), np.float32)
    image[17:23, 10:30] = inner_colour
    outer = np.array([[2, 2], [38, 2], [38, 38], [2, 38]], np.float32)
    inner = np.array([[10, 17], [30, 17], [30, 23], [10, 23]], np.float32)
    return image, outer, inner


@pytest.mark.parametrize("inner_colour, closed", [((0.55, 0.28, 0.28), True), ((0.95, 0.95, 0.9), False),
                                                  ((0.03, 0.02, 0.02), False)])
def test_teeth_or_a_dark_opening_keep_the_mouth_open(inner_colour, closed):
    image, outer, inner = lips_box(inner_colour)
    assert ll.mouth_closed(image, outer, inner) is closed


def test_a_mouth_with_no_inner_pixel_out_of_the_image_or_constant_is_closed():
    image, outer, inner = lips_box((0.95, 0.95, 0.9))
    assert ll.mouth_closed(image, outer, np.full((4, 2), 20.0, np.float32)) is True
    assert ll.mouth_closed(image, outer + 100.0, inner + 100.0) is True
    assert ll.mouth_closed(np.full_like(image, 7.0), outer, inner) is True  # a constant HDR image: nothing to tell
