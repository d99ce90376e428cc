"""Framing a photo's lips (vto_core.photo.framing): the default lips scene's square, on the pixel grid or turned."""

import numpy as np
import pytest

from vto_core.products import LIPS

from vto_core.photo.framing import (MIN_SIZE, region_frame, square_view, turned_square, view_box,
                                    view_cut)


def mask_with_box(height, width, rows, cols):
    mask = np.zeros((height, width), np.float32)
    mask[rows, cols] = 1.0
    return mask


def test_the_frame_is_a_square_the_lips_span_their_share_of():
    x, y, w, h = region_frame(mask_with_box(100, 100, slice(40, 50), slice(30, 70)), LIPS.frame_share)
    assert (x, y, w, h) == (24, 19, 52, 52)  # 40 px of lips / 0.78 -> 52, centred on (45, 50)
    assert 40 / w == pytest.approx(LIPS.frame_share, abs=0.02)


def test_the_frame_moves_inside_the_image_and_shrinks_to_fit():
    assert region_frame(mask_with_box(24, 24, slice(6, 18), slice(0, 12)), LIPS.frame_share) == (0, 4, 16, 16)  # moved right
    assert region_frame(mask_with_box(20, 40, slice(5, 15), slice(2, 38)), LIPS.frame_share) == (10, 0, 20, 20)  # shrunk, centred
    x, y, w, h = region_frame(mask_with_box(30, 30, slice(25, 30), slice(20, 30)), LIPS.frame_share)
    assert (w, h) == (13, 13) and x + w <= 30 and y + h <= 30  # a corner: still inside


def test_a_single_pixel_gets_the_smallest_usable_frame():
    assert region_frame(mask_with_box(50, 50, slice(10, 11), slice(10, 11)), LIPS.frame_share)[2:] == (MIN_SIZE, MIN_SIZE)


def test_a_tall_mask_is_not_cut():
    x, y, w, h = region_frame(mask_with_box(100, 100, slice(10, 90), slice(45, 55)), LIPS.frame_share)
    assert w == h == 80 and y <= 10 and y + h >= 90



def test_a_view_on_the_grid_cuts_exact_pixels_and_a_turned_one_turns_them():
    image = np.random.default_rng(0).random((40, 50, 3)).astype(np.float32)
    shift = np.array([[1.0, 0.0, 7], [0.0, 1.0, 5]])
    assert np.array_equal(view_cut(image, shift, 16), image[5:21, 7:23]) and view_box(shift, 16, (40, 50)) == (
        7, 5, 16, 16)
    view, size = square_view(np.array([25.0, 20.0]), 16, np.pi / 2)  # a frame turned a quarter clockwise ...
    turned = view_cut(image, view, size)
    assert size == 16 and np.allclose(turned, np.rot90(image[12:28, 17:33], 1), atol=1e-5)  # ... sees it turned back
    outside = view_cut(image, np.array([[1.0, 0.0, 100], [0.0, 1.0, 100]]), 8)
    assert outside.shape == (8, 8, 3) and not outside.any()  # black outside the image


def test_turned_lips_are_measured_along_the_face():
    outer = np.array([[0, 0], [40, 0], [20, -8], [20, 8]], np.float64)  # 40 px wide, 16 tall
    angle = np.radians(30)
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    centre, side = turned_square(outer @ turn.T + (100, 50), angle, LIPS.frame_share)
    assert side == pytest.approx(np.ceil(40 / LIPS.frame_share)) and centre == pytest.approx(turn @ (20, 0) + (100, 50))
