"""The photo made ready (vto_core.photo.photo_reader): a lips mask framed as the default lips scene frames its lips, hair
squares, photos read once, the light taken out, tilted heads read upright, photos without colour refused."""

from pathlib import Path

import numpy as np
import pytest
import skimage.data

from benchmarks.common import tilted
from vto_core.errors import VtoError
from vto_core.imageio import read_image, write_image
from vto_core.photo import photo_reader as module
from vto_core.photo.face_reader import FaceReader
from vto_core.photo.photo_reader import HAIR_SQUARE_SHARE, NO_FACE_HAIR, NO_FACE_LIGHT, PhotoReader
from vto_core.products import LIPSTICK

MODELS = Path(__file__).resolve().parents[3] / "blender_addon" / "models"
READER = PhotoReader(MODELS / "face_detector.onnx", MODELS / "face_landmarks.onnx", MODELS / "person_segmenter.onnx")


def lips_reference(whole, crop=None, mask=None, find_lips=True, neutral_light=True):
    """The lipstick's reference, as Match reads it."""
    return READER.face_region_reference(LIPSTICK, whole, crop, mask, find_lips, neutral_light)


hair_reference, face_and_hair = READER.hair_reference, READER.face_and_hair


def mask_with_box(height, width, rows, cols):
    mask = np.zeros((height, width), np.float32)
    mask[rows, cols] = 1.0
    return mask


def test_a_hair_mask_gives_the_encoder_its_largest_square_and_the_fit_all_of_it():
    whole = np.random.default_rng(0).random((60, 90, 3)).astype(np.float32)
    mask = mask_with_box(60, 90, slice(10, 50), slice(20, 80))  # 40 x 60 of hair
    reference = hair_reference(whole, mask=mask)
    x, y, side, _ = reference.box
    assert side >= 40 and mask[y:y + side, x:x + side].mean() >= HAIR_SQUARE_SHARE  # the largest square that is hair
    assert np.array_equal(reference.image, whole[y:y + side, x:x + side])
    rgb, region = reference.region
    assert rgb.shape == whole.shape and np.array_equal(region, mask)  # Better and Best read all the hair
    cropped = hair_reference(whole, crop=(20, 10, 30, 30))  # a patch: all of it is hair
    assert cropped.box == (20, 10, 30, 30) and cropped.region[1].all()


def test_hair_masks_too_thin_or_empty_are_one_line_errors():
    from vto_core.errors import VtoError

    whole = np.zeros((40, 40, 3), np.float32)
    with pytest.raises(VtoError, match="no 8x8 px square of hair"):
        hair_reference(whole, mask=mask_with_box(40, 40, slice(0, 40), slice(10, 14)))
    with pytest.raises(VtoError, match="no hair inside the crop"):
        hair_reference(whole, crop=(0, 0, 10, 10), mask=mask_with_box(40, 40, slice(20, 40), slice(20, 40)))


def test_a_lips_mask_frames_the_reference_and_is_its_region_and_whole_image_takes_it_as_it_is():
    whole = np.random.default_rng(1).random((100, 100, 3)).astype(np.float32)
    mask = mask_with_box(100, 100, slice(40, 50), slice(30, 70))
    framed = lips_reference(whole, mask=mask)
    assert framed.box == (24, 19, 52, 52) and framed.found is None and framed.notes == [framed.light.describe()]
    assert np.array_equal(framed.region[1], mask[19:71, 24:76])
    as_it_is = lips_reference(whole, mask=mask, neutral_light=False)
    assert as_it_is.light is None and as_it_is.notes == [] and np.array_equal(as_it_is.image, whole[19:71, 24:76])
    plain = lips_reference(whole, find_lips=False)
    assert plain.box == (0, 0, 100, 100) and plain.region is None and np.array_equal(plain.image, whole)


def test_a_photo_read_again_is_decoded_once_until_its_file_changes(tmp_path, monkeypatch):
    """Warm clicks on the same photo skip decoding it; each call gets its own copy, and its warnings."""
    path = tmp_path / "photo.exr"
    image = np.full((20, 20, 3), 0.25, np.float32)
    image[0, 0] = np.nan
    write_image(path, image)
    decoded = []
    read = module.read_image
    monkeypatch.setattr(module, "read_image", lambda name, **options: decoded.append(name) or read(name, **options))
    with pytest.warns(UserWarning, match="1 NaN"):
        first = module.load_reference(str(path))
    first[:] = 1.0  # the caller's own copy
    with pytest.warns(UserWarning, match="1 NaN"):
        second = module.load_reference(str(path))
    assert len(decoded) == 1 and second[0, 0].tolist() == [0, 0, 0] and np.allclose(second[1:], 0.25)
    write_image(path, np.full((24, 20, 3), 0.75, np.float32))  # a new version of the file
    assert np.allclose(module.load_reference(str(path)), 0.75) and len(decoded) == 2


@pytest.mark.parametrize("name, bits", [("photo.jpg", 8), ("photo.png", 16)])
def test_an_8_or_16_bit_photo_is_kept_as_its_integers_and_read_exactly_as_read_image_reads_it(name, bits, tmp_path):
    """The cache holds an 8-bit photo's bytes (a quarter of float32's memory: 194 MB, not 778, for 64 megapixels);
    each call gets the very floats read_image gives."""
    path = tmp_path / name
    write_image(path, np.random.default_rng(3).random((40, 30, 3)).astype(np.float32), bits=bits)
    stat = path.stat()
    cached, bad = module._decoded_reference(str(path), stat.st_mtime_ns, stat.st_size)
    assert cached.dtype == (np.uint8 if bits == 8 else np.uint16) and bad == 0 and not cached.flags.writeable
    first, second = module.load_reference(str(path)), module.load_reference(str(path))
    assert first.dtype == np.float32 and np.array_equal(first, read_image(path)[0]) and first is not second
    first[:] = 0.0  # the caller's own copy
    assert np.array_equal(second, read_image(path)[0])


def test_the_photos_light_is_taken_out_so_a_re_lit_portrait_reads_nearly_as_the_original():
    """A warm 3,200 K light on the astronaut: the framed lips come back near the original's once the light read from
    her skin is taken out, and the hair patch of the same photo likewise."""
    from vto_core.colour import srgb_to_lab
    from vto_core.photo.photo_light import kelvin_gains, relit

    photo = skimage.data.astronaut().astype(np.float32) / 255
    warm = relit(photo, kelvin_gains(3200))
    original, under_warm = lips_reference(photo), lips_reference(warm)
    raw = lips_reference(warm, neutral_light=False)
    assert "warm" in under_warm.light.describe() and under_warm.light.cast[0] > 1.3 > original.light.cast[0]

    def lips_lab(reference):  # the region's mean colour: the lips, or the hair
        rgb, mask = reference.region
        return srgb_to_lab(rgb[mask > 0.5].mean(axis=0))

    left, raw_shift = (np.linalg.norm(lips_lab(r) - lips_lab(original)) for r in (under_warm, raw))
    assert left < raw_shift / 3, (left, raw_shift)
    patch = (150, 20, 80, 70)  # her hair (benchmarks/photos/photos.json)
    hair, warm_hair = (hair_reference(image, crop=patch) for image in (photo, warm))
    raw_hair = hair_reference(warm, crop=patch, neutral_light=False)
    assert warm_hair.light is not None and "taken out" in warm_hair.notes[0] and raw_hair.light is None

    def hair_lab(reference):
        return srgb_to_lab(reference.image.mean(axis=(0, 1)))

    left, raw_shift = (np.linalg.norm(hair_lab(r) - hair_lab(hair)) for r in (warm_hair, raw_hair))
    assert left < raw_shift / 2, (left, raw_shift)  # three quarters of the cast's log read: ~60 % of its ΔE


def test_a_hair_patch_without_a_face_is_read_as_it_is_and_says_so():
    patch = np.ascontiguousarray(skimage.data.astronaut()[20:90, 150:230].astype(np.float32) / 255)
    reference = hair_reference(patch)
    assert reference.light is None and reference.hair is None and reference.notes == [NO_FACE_HAIR, NO_FACE_LIGHT]
    assert np.array_equal(reference.region[0], patch) and reference.region[1].all()
    flat = np.full((40, 40, 3), (0.4, 0.3, 0.2), np.float32)
    with pytest.raises(VtoError, match="^no hair found: the image is blank$"):
        hair_reference(flat)
    assert hair_reference(flat, find_hair=False).region[1].all()  # taken whole, as asked


def test_hair_is_found_in_a_whole_portrait_and_a_crop_or_mask_overrides_it():
    from benchmarks.hand_masks import load_records, rasterise

    photo = skimage.data.astronaut().astype(np.float32) / 255
    drawn = rasterise(load_records()["package:skimage.data.astronaut"], 512, 512)
    reference = hair_reference(photo)
    found = reference.hair.mask > 0.5
    assert (found & drawn).sum() / (found | drawn).sum() >= 0.6
    x, y, w, h = reference.hair.box
    rgb, mask = reference.region
    assert mask.shape == (h, w) and np.array_equal(mask, reference.hair.mask[y:y + h, x:x + w])  # Better, Best
    sx, sy, side, _ = reference.box
    assert found[sy:sy + side, sx:sx + side].mean() >= HAIR_SQUARE_SHARE  # the encoder reads found hair only
    assert reference.notes[0].startswith("hair found: ") and "taken out" in reference.notes[1]
    assert hair_reference(photo, crop=(150, 20, 80, 70)).hair is None  # a crop: the hair is where the artist says
    painted = np.zeros((512, 512), np.float32)
    painted[300:400, 300:400] = 1
    masked = hair_reference(photo, mask=painted)
    assert masked.hair is None and np.array_equal(masked.region[1], painted) and masked.box[2] >= 100


def test_hair_is_found_beside_the_face_in_a_tight_crop():
    """A beauty crop (her forehead's top out of frame): the hair beside her face is found, and Better and Best read
    it."""
    from benchmarks.hand_masks import load_records, rasterise

    photo = skimage.data.astronaut().astype(np.float32) / 255
    drawn = rasterise(load_records()["package:skimage.data.astronaut"], 512, 512)[75:300, 130:330]
    reference = hair_reference(np.ascontiguousarray(photo[75:300, 130:330]))
    found = reference.hair.mask > 0.5
    assert (found & drawn).sum() / (found | drawn).sum() >= 0.5
    x, y, w, h = reference.hair.box
    assert np.array_equal(reference.region[1], reference.hair.mask[y:y + h, x:x + w])
    assert reference.image.shape[0] >= 8 and reference.notes[0].startswith("hair found: ")


def test_the_last_photos_face_and_hair_are_kept_until_a_pixel_changes():
    photo = skimage.data.astronaut().astype(np.float32) / 255
    face, light, hair = face_and_hair(photo, True, True)
    again = face_and_hair(photo.copy(), True, True)
    assert again[0] is face and again[2] is hair  # the same pixels: read once
    assert np.array_equal(again[1].gains, light.gains)
    photo[300, 300] += 0.01
    changed = face_and_hair(photo, True, True)
    assert changed[2] is not hair and np.array_equal(changed[2].mask, hair.mask)
    assert face_and_hair(photo, False, True)[2] is None
    assert face_and_hair(photo, True, False)[1] is None  # the light left in: the hair found again, as it is


def test_a_second_lips_match_on_the_same_photo_reads_its_face_and_colour_once(monkeypatch):
    photo = skimage.data.astronaut().astype(np.float32) / 255
    photo[0, 0] += 0.002  # pixels no other test has read
    reads, read = [], FaceReader.read
    monkeypatch.setattr(FaceReader, "read", lambda self, image: reads.append(1) or read(self, image))
    first = lips_reference(photo)
    again = lips_reference(photo.copy())
    assert len(reads) == 1 and np.array_equal(first.image, again.image) and first.box == again.box
    facts = READER.photo_facts(photo)
    assert facts["monochrome", "lipstick", True] == ""
    photo[300, 300] += 0.01
    lips_reference(photo)
    assert len(reads) == 2  # a pixel changed: read again


def test_hair_is_found_under_a_warm_or_cool_light_as_under_a_neutral_one():
    """The hair's colours are judged with the photo's light taken out: 3,200 K made her seed look like skin (and
    other portraits' like a hat) when they were judged as the photo shows them."""
    from vto_core.photo.photo_light import kelvin_gains, relit

    photo = skimage.data.astronaut().astype(np.float32) / 255
    neutral = hair_reference(photo).hair.mask > 0.5
    for kelvin in (3200.0, 7500.0):
        found = hair_reference(relit(photo, kelvin_gains(kelvin, 0.0))).hair.mask > 0.5
        assert (found & neutral).sum() / (found | neutral).sum() >= 0.8, kelvin


@pytest.mark.parametrize("degrees", [-30, 30, 180])
def test_a_tilted_head_is_framed_upright_for_lips_and_hair(degrees):
    """The astronaut tilted: the lips and the hair square reach the encoder turned upright, near what the upright
    photo gives (each resized to the encoder's 64 px), and the panel is told."""
    from vto_core.colour import srgb_to_lab
    from vto_core.imageio import resize

    photo = skimage.data.astronaut().astype(np.float32) / 255
    photo_tilted = tilted(photo, degrees)
    upright, turned = lips_reference(photo), lips_reference(photo_tilted)
    assert upright.turn == 0.0 and abs((np.degrees(turned.turn) - degrees - 2.7 + 180) % 360 - 180) < 2
    assert f"face turned {np.degrees(turned.turn):+.0f} degrees: read upright" in turned.notes
    small = [resize(r.image, 64, 64) for r in (upright, turned)]
    assert np.abs(small[0] - small[1]).mean() < 0.05  # the same picture, not a slanted one
    sideways = resize(np.ascontiguousarray(np.rot90(upright.image)), 64, 64)
    assert np.abs(small[0] - sideways).mean() > 2 * np.abs(small[0] - small[1]).mean()

    def lips_lab(reference):  # the region's mean colour: the lips, or the hair
        rgb, mask = reference.region
        return srgb_to_lab(rgb[mask > 0.5].mean(axis=0))

    assert np.linalg.norm(lips_lab(upright) - lips_lab(turned)) < 2.0
    hair, turned_hair = hair_reference(photo), hair_reference(photo_tilted)
    assert turned_hair.turn == pytest.approx(turned.turn)
    colours = [srgb_to_lab(r.image.mean(axis=(0, 1))) for r in (hair, turned_hair)]
    assert np.linalg.norm(colours[0] - colours[1]) < 3.0
    # All the hair found, the canvas's black corners left out: within 0.36 CIELAB of upright (0.50-0.55 with them in).
    assert np.linalg.norm(lips_lab(hair) - lips_lab(turned_hair)) < 0.45


@pytest.mark.parametrize("product", ["lipstick", "hair"])
def test_black_and_white_and_toned_portraits_are_refused_in_one_line(product):
    photo = skimage.data.astronaut().astype(np.float32) / 255
    grey = np.repeat((photo @ np.array([0.2126, 0.7152, 0.0722], np.float32))[..., None], 3, axis=2)
    sepia = np.clip(grey * np.array([1.07, 0.94, 0.74], np.float32), 0, 1)
    read = lips_reference if product == "lipstick" else hair_reference
    with pytest.raises(VtoError, match=f"^a black-and-white photo has no {product} colour to read"):
        read(grey)
    with pytest.raises(VtoError, match=f"^a monochrome \\(toned\\) print has no {product} colour to read"):
        read(sepia)
    assert hair_reference(sepia[150:230, 20:100], find_hair=False).image.size  # a patch of one hue: may be hair


def test_any_face_mesh_region_is_found_and_framed_by_its_loops():
    """A region declared only by its loops (here the lips' loops under another name, so the lips' own locator is not
    used) is found on the face mesh as the lips locator finds the lips, and framed alike; a region of a face too small
    for it, or a photo without a face, is one line."""
    import dataclasses

    from vto_core.photo.framing import region_frame
    from vto_core.products import LIPS, FaceRegion

    photo = skimage.data.astronaut().astype(np.float32) / 255
    mouth = FaceRegion("mouth", LIPS.loops, LIPS.frame_share)
    lips, found = READER.locate_lips(photo), READER.locate_region(mouth, photo)
    assert found.how == "face" and np.array_equal(found.mask, lips.mask) and found.box == lips.box
    product = dataclasses.replace(LIPSTICK, name="mouth paint", face_regions=(mouth,))
    read, as_lips = READER.face_region_reference(product, photo), lips_reference(photo)
    assert read.box == as_lips.box and np.array_equal(read.image, as_lips.image)
    wide = FaceRegion("wide", LIPS.loops, LIPS.frame_share / 2)  # framed with twice the room around it
    assert region_frame(found.mask, wide.frame_share)[2] > 1.8 * region_frame(found.mask, LIPS.frame_share)[2]
    with pytest.raises(VtoError, match=r"^no mouth found: no face in the image"):
        READER.locate_region(mouth, np.full((64, 64, 3), 0.5, np.float32))
