"""Portrait lighting: rotations, the cosine integral, the key in front, neutral and metered light, extremes."""

import math

import numpy as np
import pytest

from vto_core.envlight import LUMINANCE, DistantLight, split_environment
from vto_core.portrait_light import (FACING, TARGET, axis_angle, irradiance, key_light, portrait_light,
                                     rotation_between)


def sky(height=32, width=64, sun=(0.3, 0.5, 0.8), sun_rgb=(40.0, 30.0, 20.0)):
    """A blue-ish gradient sky with one small warm sun: (H, W, 3) linear, bottom row first."""
    rows = np.linspace(0.2, 1.0, height)[:, None, None]
    rgb = np.broadcast_to(rows * np.array([0.3, 0.5, 0.9]), (height, width, 3)).copy()
    from vto_core.envlight import pixel_directions

    directions, _ = pixel_directions(height, width)
    near = directions @ (np.array(sun) / np.linalg.norm(sun)) > math.cos(0.08)
    rgb[near] = sun_rgb
    return rgb


@pytest.mark.parametrize("a,b", [((1, 0, 0), (0, 0, 1)), ((0, 0, 1), (0, 0, 1)), ((0, 0, 1), (0, 0, -1)),
                                 ((0.2, -0.7, 0.1), (-0.5, 0.1, 0.4))])
def test_rotation_between_takes_a_onto_b_and_is_a_rotation(a, b):
    r = rotation_between(np.array(a, float), np.array(b, float))
    a, b = (np.array(v, float) / np.linalg.norm(v) for v in (a, b))
    assert r @ a == pytest.approx(b, abs=1e-9)
    assert r @ r.T == pytest.approx(np.eye(3), abs=1e-9) and np.linalg.det(r) == pytest.approx(1.0)


def test_a_constant_map_gives_pi_times_its_radiance_on_any_normal():
    constant = np.full((64, 128, 3), 0.5)
    for normal in (FACING, np.array([1.0, 0, 0]), np.array([0.0, -0.6, -0.8])):
        assert irradiance(constant, [], axis_angle(np.array([0, 1.0, 0]), 0.7), normal) == pytest.approx(
            np.full(3, 0.5 * math.pi), rel=2e-3)


def test_a_light_counts_by_the_cosine_of_its_turned_direction():
    light = DistantLight(np.array([1.0, 0, 0]), np.array([2.0, 2.0, 2.0]), 0.01)
    zero = np.zeros((8, 16, 3))
    turned = rotation_between(np.array([1.0, 0, 0]), np.array([0, math.sin(0.5), math.cos(0.5)]))
    assert irradiance(zero, [light], turned) == pytest.approx(np.full(3, 2 * math.cos(0.5)))
    assert irradiance(zero, [light], np.eye(3)) == pytest.approx(np.zeros(3))  # side-on: no light on the face


def test_the_key_is_in_front_the_face_light_neutral_and_metered():
    residual, lights, _ = split_environment(sky())
    key = key_light(residual, lights)
    for seed in range(40):
        light = portrait_light(residual, lights, np.random.default_rng(seed))
        angle = math.acos(np.clip((light.rotation @ key) @ FACING, -1, 1))
        assert angle <= 0.5 + 1e-9
        falling = irradiance(residual, lights, light.rotation, FACING, light.fill) * light.tint * light.strength
        level = float(falling @ LUMINANCE)
        assert TARGET * 2 ** (-1 / 3) - 1e-9 <= level <= TARGET * 2 ** (1 / 3) + 1e-9
        shift = falling / falling[1] - 1.0  # neutral up to a warm/cool shift: (1 + d, 1, 1 - d), |d| <= 0.03
        assert shift[0] == pytest.approx(-shift[2], abs=1e-9) and abs(shift[0]) <= 0.03 + 1e-9


def test_the_sky_no_longer_tints_the_face():
    """Under the raw map the face's light is blue (the sky); after the gains it is grey up to the shift."""
    residual, lights, _ = split_environment(sky(sun_rgb=(5.0, 5.0, 5.0)))
    raw = irradiance(residual, [], np.eye(3))
    assert raw[2] / raw[0] > 2.0
    light = portrait_light(residual, [], np.random.default_rng(3), warm_cool=0.0)
    balanced = irradiance(residual, [], light.rotation, FACING, light.fill) * light.tint
    assert balanced == pytest.approx(np.full(3, balanced[1]), rel=1e-9)


@pytest.mark.parametrize("rgb", [np.zeros((8, 16, 3)), np.full((8, 16, 3), 1e-30), np.full((8, 16, 3), 7.0),
                                 np.full((8, 16, 3), 1e30)])
def test_dark_constant_and_hdr_maps_give_finite_lighting(rgb):
    residual, lights, _ = split_environment(rgb)
    light = portrait_light(residual, lights, np.random.default_rng(0))
    values = np.concatenate([light.rotation.ravel(), light.tint, [light.fill, light.strength]])
    assert np.isfinite(values).all() and light.strength > 0 and (light.tint > 0).all()
