"""The bare lips from the skin beside them (vto_core.photo.bare_lips)."""

import numpy as np
import pytest

from vto_core.photo.bare_lips import RATIO_AT_1, RATIO_SLOPE, bare_lips, lips_ratio

LIGHT_SKIN = np.array([0.42, 0.20, 0.13])  # linear: a typical light training face (data/faces)
DARK_SKIN = np.array([0.21, 0.086, 0.033])
LUMINANCE = float(LIGHT_SKIN @ [0.2126, 0.7152, 0.0722])


def test_bare_lips_are_redder_than_the_skin_they_sit_in():
    lips = bare_lips(LIGHT_SKIN)
    assert lips[1] / lips[0] < LIGHT_SKIN[1] / LIGHT_SKIN[0] - 0.03  # less green for their red
    np.testing.assert_allclose(lips, LIGHT_SKIN * np.exp(RATIO_SLOPE * np.log(LUMINANCE) + RATIO_AT_1), rtol=1e-3)


def test_darker_skins_have_lips_nearer_their_own_colour():
    assert (lips_ratio(DARK_SKIN) > lips_ratio(LIGHT_SKIN)).all()


def test_the_ratio_does_not_depend_on_the_lights_colour_only_on_the_skins_lightness():
    warm = LIGHT_SKIN * np.array([1.3, 1.0, 0.6])
    warm *= LUMINANCE / float(warm @ [0.2126, 0.7152, 0.0722])  # the same luminance under a warm light
    np.testing.assert_allclose(bare_lips(warm) / warm, lips_ratio(LIGHT_SKIN), rtol=2e-3)


@pytest.mark.parametrize("skin", [np.zeros(3), np.full(3, 1e6), np.array([np.nan, 0.2, 0.1]),
                                  np.array([-1.0, 0.2, 0.1]), np.array([np.inf, 0.2, 0.1])])
def test_any_skin_gives_finite_bare_lips(skin):
    lips = bare_lips(skin)
    assert lips.shape == (3,) and np.isfinite(lips).all() and (lips >= 0).all()
