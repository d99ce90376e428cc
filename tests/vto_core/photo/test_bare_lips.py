"""The bare lips from the skin beside them (vto_core.photo.bare_lips)."""

import numpy as np
import pytest

from vto_core.colour import luminance
from vto_core.photo.bare_lips import (CHROMA_RANGE, COEFFICIENTS, DARK_KNEE, DARK_SLOPE, RATIO_SLOPE, bare_lips,
                                      features, lips_ratio)

LIGHT_SKIN = np.array([0.42, 0.20, 0.13])  # linear: a typical light training face (data/faces)
DARK_SKIN = np.array([0.21, 0.086, 0.033])
LUMINANCE = float(LIGHT_SKIN @ [0.2126, 0.7152, 0.0722])


def test_bare_lips_are_redder_than_the_skin_they_sit_in():
    lips = bare_lips(LIGHT_SKIN)
    assert lips[1] / lips[0] < LIGHT_SKIN[1] / LIGHT_SKIN[0] - 0.03  # less green for their red
    terms = np.array([1.0, np.log(0.42 / 0.20), np.log(0.13 / 0.20)])
    np.testing.assert_allclose(lips, LIGHT_SKIN * np.exp(RATIO_SLOPE * np.log(LUMINANCE) + terms @ COEFFICIENTS),
                               rtol=1e-3)


def test_darker_skins_have_lips_nearer_their_own_colour():
    assert (lips_ratio(DARK_SKIN) > lips_ratio(LIGHT_SKIN)).all()


def test_a_black_skins_lips_are_lighter_than_the_skin():
    # a black training face of the London Set: skin L* 25.5, its lips L* 32.5 (guessed 4-5 L* too dark before the knee)
    skin = np.array([0.064, 0.041, 0.035])
    assert luminance(bare_lips(skin)) > 1.2 * luminance(skin)


def test_below_the_knee_the_ratio_climbs_by_both_slopes():
    at_knee = LIGHT_SKIN * DARK_KNEE / LUMINANCE
    np.testing.assert_allclose(lips_ratio(at_knee * 1.5) / lips_ratio(at_knee), 1.5 ** RATIO_SLOPE, rtol=1e-6)
    np.testing.assert_allclose(lips_ratio(at_knee / 2.0) / lips_ratio(at_knee), 0.5 ** (RATIO_SLOPE + DARK_SLOPE),
                               rtol=1e-6)


def test_a_less_red_skin_has_lips_darker_and_redder_against_it():
    # the London Set's studio skins (red over green 1.6) against data/faces' (2.1), at the same luminance
    pale = np.array([0.34, 0.2125, 0.15])
    pale *= LUMINANCE / float(pale @ [0.2126, 0.7152, 0.0722])
    ratio, light = lips_ratio(pale), lips_ratio(LIGHT_SKIN)
    assert ratio[1] < light[1] - 0.05
    assert ratio[0] / ratio[1] > light[0] / light[1]


def test_an_exposure_moves_the_ratio_by_the_luminance_slope_alone():
    # chroma does not change with an exposure, so a photo +1 EV brighter moves r only as RATIO_SLOPE says
    np.testing.assert_allclose(lips_ratio(LIGHT_SKIN * 2.0) / lips_ratio(LIGHT_SKIN), 2.0 ** RATIO_SLOPE, rtol=1e-9)


def test_a_skin_chroma_outside_the_training_range_reads_as_its_edge():
    edge = np.array([np.exp(CHROMA_RANGE[0][1]), 1.0, np.exp(CHROMA_RANGE[1][0])]) * 0.2
    far = np.array([np.exp(CHROMA_RANGE[0][1] + 2.0), 1.0, np.exp(CHROMA_RANGE[1][0] - 2.0)]) * 0.2
    np.testing.assert_allclose(features(far), features(edge))


@pytest.mark.parametrize("skin", [np.zeros(3), np.full(3, 1e6), np.array([np.nan, 0.2, 0.1]),
                                  np.array([-1.0, 0.2, 0.1]), np.array([np.inf, 0.2, 0.1])])
def test_any_skin_gives_finite_bare_lips(skin):
    lips = bare_lips(skin)
    assert lips.shape == (3,) and np.isfinite(lips).all() and (lips >= 0).all()
