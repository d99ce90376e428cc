"""The reference's Blender side (blender_addon.matching.reference): the default scene's lips framed as a photo's are, an
image datablock read as its file is, and the thumbnail and batch reading a photo as Match does."""

import numpy as np
import pytest

from vto_core.imageio import write_image
from vto_core.photo.framing import region_frame
from vto_core.products import LIPS


def mask_with_box(height, width, rows, cols):
    mask = np.zeros((height, width), np.float32)
    mask[rows, cols] = 1.0
    return mask


@pytest.mark.blender
def test_the_default_scene_frames_its_lips_as_lips_frame_does():
    """Framing a default render by its own lips mask gives (about) the whole render back."""
    pytest.importorskip("bpy")
    from blender_addon.renderers.scene_lips import lips_mask

    for source in range(8):
        x, y, w, h = region_frame(lips_mask(source, 128), LIPS.frame_share)
        assert 0.85 * 128 <= w <= 128, (source, w)


def test_the_thumbnail_and_batch_read_a_tight_crop_as_match_does(tmp_path):
    import skimage.data

    from blender_addon.matching.batch import batch_reference
    from blender_addon.shipped import photo_reader
    from blender_addon.ui.thumbnail import HAIR_COLOUR, SIZE, compose

    crop = np.ascontiguousarray(skimage.data.astronaut()[75:300, 130:330].astype(np.float32) / 255)
    write_image(tmp_path / "tight.png", crop)
    batch = batch_reference("hair", tmp_path / "tight.png")
    assert batch.hair is not None and np.array_equal(batch.hair.mask, photo_reader().hair_reference(crop).hair.mask)
    green = np.all(np.isclose(compose(crop, None, None, hair=batch.hair)[..., :3], HAIR_COLOUR), axis=-1)
    cols = np.nonzero(green)[1]
    assert cols.min() < 0.3 * SIZE and cols.max() > 0.7 * SIZE  # outlined on both sides of her face


@pytest.mark.blender
def test_an_image_datablock_is_turned_as_its_files_orientation_says(tmp_path):
    import bpy

    from blender_addon.matching.reference import datablock_pixels

    shown = np.zeros((24, 40, 3), np.float32)
    shown[:8, :8] = (1.0, 0.0, 0.0)  # red at the top left as a viewer shows it
    stored = np.ascontiguousarray(np.rot90(shown, 1))  # Orientation 6: the viewer turns it 90 degrees clockwise
    path = write_image(tmp_path / "phone.jpg", stored, orientation=6)
    image = bpy.data.images.load(str(path))
    try:
        assert tuple(image.size) == (24, 40)  # Blender keeps the stored pixels
        from_file = datablock_pixels(image)
        image.pixels[0] = image.pixels[0]  # edited in Blender: read from its pixels, still turned as shown
        assert image.is_dirty
        from_pixels = datablock_pixels(image)
        for pixels in (from_file, from_pixels):
            assert pixels.shape == (24, 40, 3) and np.abs(pixels - shown).mean() < 0.02
            assert pixels[:6, :6, 0].mean() > 0.9 and pixels[-6:, -6:, 0].mean() < 0.1  # red at the top left
    finally:
        bpy.data.images.remove(image)
