"""Splitting an environment map into a residual and distant lights: light conserved, spots found where they are."""

import numpy as np
import pytest

from vto_core.envlight import LUMINANCE, pixel_directions, split_environment
from vto_core.errors import VtoError


def _sky(height=32, width=64):
    """A dim blue sky with a small, very bright warm sun at azimuth 90 deg (+y), elevation ~40 deg."""
    rgb = np.tile(np.array([0.2, 0.3, 0.5]), (height, width, 1))
    directions, _ = pixel_directions(height, width)
    sun = np.array([0.0, np.cos(np.radians(40)), np.sin(np.radians(40))])
    rgb[(directions @ sun) > np.cos(np.radians(6))] = (900.0, 700.0, 500.0)
    return rgb, sun


def _irradiance_integral(rgb):
    _, solid_angle = pixel_directions(*rgb.shape[:2])
    return (rgb * solid_angle[..., None]).sum(axis=(0, 1))


def test_pixel_solid_angles_cover_the_sphere():
    directions, solid_angle = pixel_directions(16, 32)
    assert solid_angle.sum() == pytest.approx(4 * np.pi, rel=2e-3)
    assert np.allclose(np.linalg.norm(directions, axis=-1), 1.0)
    assert directions[0, 0, 2] < -0.9 and directions[-1, 0, 2] > 0.9  # bottom row first: looking down


def test_a_sun_becomes_one_light_and_light_is_conserved():
    rgb, sun = _sky()
    residual, lights, dropped = split_environment(rgb)
    assert len(lights) == 1 and dropped < 1e-12
    assert np.degrees(np.arccos(lights[0].direction @ sun)) < 3.0
    assert lights[0].irradiance[0] > lights[0].irradiance[2]  # warm
    assert np.allclose(_irradiance_integral(residual) + lights[0].irradiance, _irradiance_integral(rgb), rtol=1e-9)
    mean = (_irradiance_integral(rgb) @ LUMINANCE) / (4 * np.pi)
    assert (residual @ LUMINANCE).max() <= 3.0 * mean * (1 + 1e-9)
    assert 0.0 < lights[0].angle < np.radians(20)


@pytest.mark.parametrize("rgb", [np.zeros((8, 16, 3)), np.full((8, 16, 3), 0.7)])
def test_dark_and_uniform_maps_give_no_lights(rgb):
    residual, lights, dropped = split_environment(rgb)
    assert lights == [] and dropped == 0.0 and np.array_equal(residual, rgb)


def test_bad_maps_are_refused():
    with pytest.raises(VtoError, match="NaN or inf"):
        split_environment(np.full((4, 8, 3), np.inf))
    with pytest.raises(VtoError, match=r"\(H, W, 3\)"):
        split_environment(np.zeros((4, 8)))


def test_spots_beyond_max_lights_are_dropped_and_counted():
    rgb, _ = _sky()
    rgb[5, 5] = rgb[5, 40] = (400.0, 400.0, 400.0)
    residual, lights, dropped = split_environment(rgb, max_lights=1, min_share=0.0)
    assert len(lights) == 1 and 0.0 < dropped < 0.5
    assert np.isfinite(residual).all()


def test_label_spots_matches_scipy_ndimage_label():
    """The numpy labelling (Blender's Python has no scipy) gives scipy's labels, numbering included."""
    ndimage = pytest.importorskip("scipy.ndimage")
    from vto_core.envlight import label_spots

    rng = np.random.default_rng(3)
    masks = [rng.random(rng.integers(1, 30, 2)) < rng.random() for _ in range(200)]
    snake = np.zeros((41, 41), bool)
    snake[::2] = True
    snake[1::4, -1] = True
    snake[3::4, 0] = True
    for mask in masks + [snake, np.zeros((4, 5), bool), np.ones((3, 7), bool)]:
        expected, count = ndimage.label(mask)
        labels, got = label_spots(mask)
        assert got == count and np.array_equal(labels, expected)
