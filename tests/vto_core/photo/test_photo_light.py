"""The photo's light read from the skin and taken out (vto_core.photo.photo_light): reference values, invariance,
extremes."""

import numpy as np
import pytest

from vto_core.colour import srgb_to_linear
from vto_core.photo.photo_light import (ANY_CAST_SIGMA, MAX_GAIN, SKIN_LOG_MEAN, kelvin_gains, light_from_skin,
                                        light_of, neutral_photo, read_gain, relit)

TYPICAL_SKIN = np.exp(SKIN_LOG_MEAN)


def face(skin=(0.75, 0.55, 0.45), lips=(0.6, 0.2, 0.3), size=40) -> tuple[np.ndarray, np.ndarray]:
    """A flat display-sRGB 'face' (size, size, 3): skin, and lips (a band in the middle) with their mask."""
    image = np.empty((size, size, 3), np.float32)
    image[:] = skin
    mask = np.zeros((size, size), np.float32)
    mask[18:23, 12:28] = 1.0
    image[mask > 0] = lips
    return image, mask


def test_a_typical_skin_reads_as_no_light_and_is_left_as_it_is():
    light = light_from_skin(TYPICAL_SKIN)
    np.testing.assert_allclose(light.gains, 1.0, atol=1e-6)
    assert light.read_from == "skin"
    image, _ = face()
    np.testing.assert_allclose(neutral_photo(image, light), image, atol=2e-3)


def test_a_colour_cast_is_read_as_light_and_a_darker_skin_as_skin():
    warm = light_from_skin(TYPICAL_SKIN * kelvin_gains(3200))
    assert warm.cast[0] > 1.3 and warm.cast[2] < 0.6  # most of the cast is read
    assert "warm" in warm.describe() and "cool" in light_from_skin(TYPICAL_SKIN * kelvin_gains(12000)).describe()
    darker = light_from_skin(TYPICAL_SKIN / 4)  # two stops: a darker skin, or a dark exposure: read as neither
    np.testing.assert_allclose(darker.gains, 1.0, atol=0.02)


def test_a_skin_the_default_scene_could_show_reads_as_almost_no_light_and_a_cast_as_light():
    """The mixture: a skin 8 % redder than the typical one (the default scene's own spread) is a skin, where the wide
    Gaussian alone would read most of it as light; the same skin under 3,200 K reads as that light."""
    redder = TYPICAL_SKIN * np.array([1.08, 1.0, 0.95])
    assert np.abs(np.log(light_from_skin(redder).gains)).max() < 0.02
    assert np.abs(read_gain(ANY_CAST_SIGMA) @ np.log(redder / TYPICAL_SKIN)).max() > 0.04
    cast = np.log(light_from_skin(redder * kelvin_gains(3200)).gains)
    wanted = np.log(kelvin_gains(3200)) - np.log(kelvin_gains(3200)).mean()  # the cast, without its exposure
    np.testing.assert_allclose(cast, wanted, atol=0.15)


def test_under_a_strong_cast_a_second_light_leaves_only_the_unread_part_of_it():
    """Where the light read is (almost) all the wide prior's: log k(s g) - log k(s) = A log g, A =
    read_gain(ANY_CAST_SIGMA)."""
    skin = TYPICAL_SKIN * kelvin_gains(3500)
    for gains in (kelvin_gains(4500), kelvin_gains(4500, 0.5), kelvin_gains(6504, -0.7)):
        shifted = light_from_skin(skin * gains).gains / light_from_skin(skin).gains
        np.testing.assert_allclose(np.log(shifted), read_gain(ANY_CAST_SIGMA) @ np.log(gains), atol=0.01)


def test_a_re_lit_photo_reads_back_near_the_original():
    image, mask = face()
    for gains in (kelvin_gains(3200), kelvin_gains(15000, -0.5)):
        back = srgb_to_linear(neutral_photo(relit(image, gains), light_of(relit(image, gains), mask)))
        before = srgb_to_linear(neutral_photo(image, light_of(image, mask)))
        raw = srgb_to_linear(relit(image, gains))
        chroma = lambda rgb: np.log(rgb[20, 20] / rgb[20, 20].mean())  # noqa: E731 (the lips' colour, no exposure)
        left, unread = np.abs(chroma(back) - chroma(before)).max(), np.abs(chroma(raw) - chroma(before)).max()
        assert left < unread / 2, (gains, left, unread)


def test_kelvin_gains_reference_values():
    np.testing.assert_allclose(kelvin_gains(6504), 1.0, atol=1e-9)
    np.testing.assert_allclose(kelvin_gains(6504, 1.0), 2.0, atol=1e-9)
    warm, cool = kelvin_gains(3200), kelvin_gains(7500)
    assert warm[1] == cool[1] == 1.0  # green kept
    np.testing.assert_allclose(warm, (1.83, 1.0, 0.36), atol=0.02)
    assert cool[0] < 1.0 < cool[2]


def test_no_skin_reads_no_light_and_the_photo_is_untouched():
    light = light_from_skin(None)
    assert light.read_from == "none" and "no skin" in light.describe()
    image = np.random.default_rng(0).random((8, 8, 3)).astype(np.float32)
    assert neutral_photo(image, light) is not None
    np.testing.assert_array_equal(neutral_photo(image, light), image)
    empty = np.zeros((8, 8), np.float32)
    assert light_of(image, empty).read_from == "none"


@pytest.mark.parametrize("skin", [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (np.nan, 0.2, np.inf), (50.0, 1e-9, 0.3),
                                  (-1.0, 0.5, 0.5)])
def test_extreme_skins_give_finite_bounded_gains_and_images(skin):
    light = light_from_skin(np.array(skin))
    assert np.isfinite(light.gains).all()
    assert (light.gains >= 1 / MAX_GAIN).all() and (light.gains <= MAX_GAIN).all()
    image, _ = face()
    out = neutral_photo(image, light)
    assert np.isfinite(out).all() and out.min() >= 0.0 and out.max() <= 1.0


def test_hdr_and_constant_images_stay_in_range():
    hdr = np.full((6, 6, 3), 40.0, np.float32)
    assert relit(hdr, kelvin_gains(3000)).max() <= 1.0
    constant, mask = np.full((12, 12, 3), 0.5, np.float32), np.zeros((12, 12), np.float32)
    mask[5:7, 4:8] = 1
    assert np.isfinite(neutral_photo(constant, light_of(constant, mask))).all()


def test_a_wider_light_prior_reads_more_of_a_cast_and_none_reads_exposure():
    narrow, wide = read_gain(0.05), read_gain(1.0)
    cast = np.array([1.0, 0.0, -1.0])
    assert np.linalg.norm(wide @ cast) > 0.9 * np.linalg.norm(cast) > np.linalg.norm(narrow @ cast) * 5
    np.testing.assert_allclose(wide @ np.ones(3), 0.0, atol=0.05)


def test_a_large_photo_is_re_lit_through_tables_within_1e_4_of_the_exact_curves():
    rng = np.random.default_rng(3)
    small = rng.random((20, 20, 3)).astype(np.float32)
    large = np.tile(small, (60, 60, 1))  # 1,440,000 values: read from the tables
    gains = kelvin_gains(3200, 0.4)
    np.testing.assert_allclose(relit(large, gains), np.tile(relit(small, gains), (60, 60, 1)), atol=1e-4)


def test_a_grey_skin_reads_no_light_and_changes_nothing():
    light = light_from_skin(np.array([0.2, 0.2, 0.2]))
    assert light.read_from == "grey" and np.allclose(light.gains, 1.0) and "no colour" in light.describe()
    image = np.random.default_rng(1).random((4, 5, 3)).astype(np.float32)
    assert np.array_equal(neutral_photo(image, light), image)
    assert light_from_skin(np.array([0.2, 0.21, 0.2])).read_from == "skin"  # 5 % apart is a colour


def test_a_large_photo_is_re_lit_a_few_rows_at_a_time_as_in_one_pass():
    """The table path reads a large image in parts (no image-sized temporaries): the same values as one pass, for a
    photo (H, W, 3), a part of one (a view) and a list of pixels (N, 3)."""
    from vto_core.colour import linear_to_srgb
    from vto_core.photo.photo_light import TABLE_LINEAR, TABLE_PIXELS_AT_ONCE, TABLE_SIZE

    rng = np.random.default_rng(8)
    photo = (rng.random((2 * TABLE_PIXELS_AT_ONCE // 700 + 3, 700, 3)) * 1.2 - 0.1).astype(np.float32)
    photo[5, 7] = (np.nan, np.inf, -np.inf)
    gains = kelvin_gains(3200, 0.4)
    curves = np.clip(linear_to_srgb(np.clip(TABLE_LINEAR[:, None] * gains.astype(np.float32), 0.0, 1.0)), 0.0, 1.0)

    def one_pass(image):
        image = np.clip(np.nan_to_num(np.asarray(image, np.float32), nan=0.0), 0.0, 1.0)
        return curves[(image * (TABLE_SIZE - 1) + 0.5).astype(np.int32), np.arange(3)]

    for image in (photo, photo[10:, 50:650], photo.reshape(-1, 3)):
        assert np.array_equal(relit(image, gains), one_pass(image))
