"""A lips mask frames the reference as the default lips scene frames its lips (blender_addon.reference.lips_frame)."""

import numpy as np
import pytest

from blender_addon.reference import LIPS_WIDTH_SHARE, MIN_SIZE, lips_frame


def mask_with_box(height, width, rows, cols):
    mask = np.zeros((height, width), np.float32)
    mask[rows, cols] = 1.0
    return mask


def test_the_frame_is_a_square_the_lips_span_their_share_of():
    x, y, w, h = lips_frame(mask_with_box(100, 100, slice(40, 50), slice(30, 70)))
    assert (x, y, w, h) == (24, 19, 52, 52)  # 40 px of lips / 0.78 -> 52, centred on (45, 50)
    assert 40 / w == pytest.approx(LIPS_WIDTH_SHARE, abs=0.02)


def test_the_frame_moves_inside_the_image_and_shrinks_to_fit():
    assert lips_frame(mask_with_box(24, 24, slice(6, 18), slice(0, 12))) == (0, 4, 16, 16)  # moved right
    assert lips_frame(mask_with_box(20, 40, slice(5, 15), slice(2, 38))) == (10, 0, 20, 20)  # shrunk, centred
    x, y, w, h = lips_frame(mask_with_box(30, 30, slice(25, 30), slice(20, 30)))
    assert (w, h) == (13, 13) and x + w <= 30 and y + h <= 30  # a corner: still inside


def test_a_single_pixel_gets_the_smallest_usable_frame():
    assert lips_frame(mask_with_box(50, 50, slice(10, 11), slice(10, 11)))[2:] == (MIN_SIZE, MIN_SIZE)


def test_a_tall_mask_is_not_cut():
    x, y, w, h = lips_frame(mask_with_box(100, 100, slice(10, 90), slice(45, 55)))
    assert w == h == 80 and y <= 10 and y + h >= 90


@pytest.mark.blender
def test_the_default_scene_frames_its_lips_as_lips_frame_does():
    """Framing a default render by its own lips mask gives (about) the whole render back."""
    pytest.importorskip("bpy")
    from blender_addon.scene_lips import lips_mask

    for source in range(8):
        x, y, w, h = lips_frame(lips_mask(source, 128))
        assert 0.85 * 128 <= w <= 128, (source, w)
