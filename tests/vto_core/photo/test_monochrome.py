"""No colour, no answer: black-and-white photos and toned prints are told from colour photos
(vto_core.photo.monochrome)."""

import numpy as np
import pytest

from vto_core.photo.monochrome import GREY_CHROMA, MIN_SPREAD, colour_spread, grey_chroma, lab_of, monochrome_problem

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)


def grey(image):
    return np.repeat((image @ LUMA)[..., None], 3, axis=2)


def test_a_colour_portrait_and_a_desaturated_one_are_kept(astronaut, hopper):
    for photo in (astronaut, hopper, grey(astronaut) + 0.4 * (astronaut - grey(astronaut))):
        assert monochrome_problem(photo, "lipstick") == ""
        assert colour_spread(lab_of(photo)) > 3 * MIN_SPREAD


@pytest.mark.parametrize("product", ["lipstick", "hair"])
def test_black_and_white_is_refused_in_one_line_naming_the_product(astronaut, product):
    problem = monochrome_problem(grey(astronaut), product)
    assert problem.startswith(f"a black-and-white photo has no {product} colour to read") and "\n" not in problem
    assert grey_chroma(lab_of(grey(astronaut))) < GREY_CHROMA


@pytest.mark.parametrize("tone", [(1.07, 0.94, 0.74), (0.55, 0.75, 1.0)])  # sepia, a blue print
def test_a_toned_print_is_refused_unless_only_black_and_white_is_checked(astronaut, tone):
    toned = np.clip(grey(astronaut) * np.array(tone, np.float32), 0, 1)
    assert grey_chroma(lab_of(toned)) > GREY_CHROMA  # it has chroma, yet one hue
    assert monochrome_problem(toned, "lipstick").startswith("a monochrome (toned) print has no lipstick colour")
    assert monochrome_problem(toned, "hair", toned=False) == ""  # a patch of grey hair is near one hue too


def test_extremes_are_finite_and_flat_pictures_are_left_to_the_locators():
    for image in (np.zeros((40, 40, 3)), np.ones((40, 40, 3)), np.full((1, 1, 3), 0.5)):
        assert monochrome_problem(image.astype(np.float32), "lipstick") == ""
    wild = np.random.default_rng(0).normal(0, 5, (30, 50, 3)).astype(np.float32)
    wild[0, 0] = np.nan
    wild[1, 1] = np.inf
    lab = lab_of(wild)
    assert np.isfinite(lab).all() and np.isfinite(colour_spread(lab)) and np.isfinite(grey_chroma(lab))
    assert colour_spread(np.zeros((0, 3))) == 0.0
