"""What a fit reads of a region (vto_core.appearance): the mean and body colour and the statistics vector."""

import numpy as np
import pytest

from vto_core.appearance import MEAN_WEIGHT, body_colour, mean_colour, region_statistics, skin_below, skin_colour
from vto_core.colour import srgb_to_lab, srgb_to_linear
from vto_core.errors import VtoError


def test_a_constant_region_reads_its_colour_and_no_spread():
    rgb = np.full((6, 7, 3), (0.8, 0.3, 0.4), np.float32)
    mask = np.zeros((6, 7), np.float32)
    mask[1:5, 2:6] = 1.0
    stats = region_statistics(rgb, mask)
    lab = srgb_to_lab(np.array([0.8, 0.3, 0.4]))
    np.testing.assert_allclose(stats[:3], MEAN_WEIGHT * lab, atol=1e-3)
    np.testing.assert_allclose(stats[3:7], lab[0], atol=1e-3)  # every lightness quantile is the one lightness
    np.testing.assert_allclose(mean_colour(rgb, mask), (0.8, 0.3, 0.4), atol=1e-6)


def test_only_the_masked_pixels_count():
    rgb = np.zeros((4, 4, 3), np.float32)
    rgb[:2] = (1.0, 0.0, 0.0)
    mask = np.zeros((4, 4))
    mask[:2] = 1
    np.testing.assert_allclose(mean_colour(rgb, mask), (1.0, 0.0, 0.0))
    rgb[3, 3] = (0.0, 1.0, 0.0)  # outside the mask: changes nothing
    np.testing.assert_allclose(region_statistics(rgb, mask), region_statistics(np.where(mask[..., None] > 0, rgb, 0.5),
                                                                                mask))


def test_highlights_show_in_the_top_lightness_quantile_and_not_in_the_body_colour():
    rng = np.random.default_rng(0)
    rgb = np.full((20, 20, 3), (0.6, 0.2, 0.25), np.float32) + rng.normal(0, 0.01, (20, 20, 3)).astype(np.float32)
    mask = np.ones((20, 20))
    plain = region_statistics(rgb, mask)
    rgb[0, :10] = 1.0  # 10 of 400 pixels: a small highlight
    glossy = region_statistics(rgb, mask)
    assert glossy[6] - plain[6] > 20  # the 0.98 lightness quantile sees it
    assert abs(glossy[4] - plain[4]) < 0.5  # the median does not
    np.testing.assert_allclose(body_colour(rgb, mask), (0.6, 0.2, 0.25), atol=0.01)


def test_extremes_are_finite_and_an_empty_region_is_one_line():
    mask = np.ones((8, 8))
    for rgb in (np.zeros((8, 8, 3)), np.ones((8, 8, 3)), np.full((8, 8, 3), 1e6), np.full((8, 8, 3), np.nan)):
        assert np.isfinite(region_statistics(rgb, mask)).all()
    with pytest.raises(VtoError, match="pixel"):
        region_statistics(np.zeros((8, 8, 3)), np.zeros((8, 8)))
    with pytest.raises(VtoError, match="mask"):
        region_statistics(np.zeros((8, 8, 3)), np.ones((4, 4)))


def test_the_skin_colour_is_the_linear_mean_beside_the_lips_and_none_without_skin():
    rgb = np.full((40, 40, 3), (0.9, 0.6, 0.5), np.float32)
    lips = np.zeros((40, 40), np.float32)
    lips[18:22, 12:28] = 1.0
    rgb[18:22, 12:28] = (0.7, 0.1, 0.2)  # the lips' own colour does not count
    rgb[17:23, 11:29] = np.where(lips[17:23, 11:29, None] > 0, rgb[17:23, 11:29], (0.1, 0.1, 0.1))  # nor the mouth's
    np.testing.assert_allclose(skin_colour(rgb, lips), srgb_to_linear(np.array([0.9, 0.6, 0.5])), rtol=1e-5)
    assert skin_colour(rgb, np.ones((40, 40))) is None  # lips fill the picture: a close crop shows no skin
    assert skin_colour(rgb, np.zeros((40, 40))) is None
    assert np.isfinite(skin_colour(np.full((40, 40, 3), np.nan), lips)).all()


def test_the_skin_below_a_lid_is_the_cheeks_median_whatever_hair_lies_above_it():
    """skin_below: a fringe of dark hair over the brow and a few dark lashes below the lid pull skin_colour's mean
    down; the cheek's per-channel median stays the cheek's. None where the lid reaches the frame's bottom."""
    rgb = np.full((40, 40, 3), (0.9, 0.6, 0.5), np.float32)
    lid = np.zeros((40, 40), np.float32)
    lid[14:20, 10:30] = 1.0
    rgb[:12] = (0.1, 0.08, 0.06)  # hair above the lid
    rgb[23, 10:14] = (0.0, 0.0, 0.0)  # lashes below it: 4 of the cheek's pixels
    cheek = srgb_to_linear(np.array([0.9, 0.6, 0.5]))
    np.testing.assert_allclose(skin_below(rgb, lid), cheek, rtol=1e-5)
    assert (skin_colour(rgb, lid) < 0.8 * cheek).all()
    low = np.zeros((40, 40), np.float32)
    low[34:40, 10:30] = 1.0
    assert skin_below(rgb, low) is None and skin_below(rgb, np.zeros((40, 40))) is None
    for frame in (np.full((40, 40, 3), np.nan), np.full((40, 40, 3), 40.0), np.zeros((40, 40, 3))):
        assert np.isfinite(skin_below(frame, lid)).all()


def test_the_skin_around_the_lips_is_read_in_its_own_box_as_the_whole_image_definition_gives_it():
    """skin_around per axis (a 64-megapixel photo's lips cost vectors, not whole-image grids) against its definition on
    the whole pixel grid, and skin_colour from the box's pixels against the mean over that whole-image mask."""
    from vto_core.appearance import skin_around

    rng = np.random.default_rng(5)
    for _ in range(60):
        height, width = (int(v) for v in rng.integers(6, 70, 2))
        lips = np.zeros((height, width), np.float32)
        y, x = int(rng.integers(0, height)), int(rng.integers(0, width))
        lips[y:y + int(rng.integers(1, 15)), x:x + int(rng.integers(1, 25))] = 1.0
        lips[rng.random((height, width)) < 0.01] = np.nan  # NaN is no lips
        inside = np.nan_to_num(lips) > 0.5
        rows, cols = np.nonzero(inside)
        wide = cols.max() + 1 - cols.min()
        cy, cx = (rows.min() + rows.max() + 1) / 2, (cols.min() + cols.max() + 1) / 2
        yy, xx = np.mgrid[:height, :width] + 0.5
        grow = 0.1 * wide
        expected = ((np.abs(xx - cx) < 0.65 * wide) & (np.abs(yy - cy) < 0.5 * wide)
                    & ~((xx > cols.min() - grow) & (xx < cols.max() + 1 + grow) & (yy > rows.min() - grow)
                        & (yy < rows.max() + 1 + grow)))
        assert np.array_equal(skin_around(lips), expected)
        rgb = rng.random((height, width, 3)).astype(np.float32)
        colour = skin_colour(rgb, lips)
        if expected.sum() < 4:
            assert colour is None
        else:
            assert np.array_equal(colour, srgb_to_linear(rgb[expected]).mean(axis=0, dtype=np.float64))
