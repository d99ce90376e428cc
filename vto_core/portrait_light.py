"""Portrait lighting for the default lips scene: a key light in front of the face, neutral light, metered exposure.

Photos of lips (portraits, selfies, product shots) are lit from the camera's side and exposed and white-balanced by
the camera on the light falling on the face. Under an environment map at any rotation the lips are as often lit
from behind and tinted by a blue sky, and their colour cannot be told from the light's. This module turns one
environment map (already split into a residual map and distant lights, vto_core.envlight) into that kind of light:

- rotation: the map is turned so that its strongest light (the key) comes from within `key_cone` radians of the
  camera's axis (+z, the way the lips face), with a random roll about that direction for variety;
- white balance: per-channel gains make the light falling on a surface facing the camera neutral, then a camera's
  residual error is kept (a warm/cool shift of a few hundred kelvin);
- exposure: one scale puts that light at `target` (a white surface facing the camera then reads target / pi), with
  the camera's residual error of up to `exposure_ev` stops either way;
- fill: the residual map (the soft fill) is scaled against the lights by a random factor before metering.

Shapes: maps are (H, W, 3) linear radiance, bottom row first, as in envlight; directions (3,) unit vectors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .envlight import LUMINANCE, DistantLight, pixel_directions

FACING = np.array([0.0, 0.0, 1.0])  # the lips' normal and the direction towards the camera
TARGET = math.pi  # luminance of the metered irradiance: a white surface facing the camera reads 1.0
KEY_CONE = 0.5  # radians between the key light and the camera's axis, at most
EXPOSURE_EV = 1.0 / 3.0  # the camera's residual exposure error, stops either way
WARM_COOL = 0.03  # the camera's residual white-balance error: R and B gains (1 + d, 1, 1 - d), |d| <= this
FILL_RANGE = (0.6, 1.6)  # the residual map's scale against the lights, before metering


@dataclass(frozen=True)
class PortraitLight:
    """How to light a scene with one split map: `rotation` (3, 3) turns map directions into world directions;
    the map's radiance and each light's irradiance are multiplied by `fill` (the map only), then by `strength` and
    the colour gains `tint` (3,)."""

    rotation: np.ndarray
    fill: float
    strength: float
    tint: np.ndarray

    @property
    def lookup(self) -> np.ndarray:
        """(3, 3) world direction -> map direction: what a Mapping node's rotation must be."""
        return self.rotation.T


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking unit vector a onto unit vector b (a half turn when they are opposite)."""
    a, b = (np.asarray(v, np.float64) / np.linalg.norm(v) for v in (a, b))
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis), float(a @ b)
    if sin < 1e-12:
        if cos > 0:
            return np.eye(3)
        helper = np.eye(3)[np.argmin(np.abs(a))]
        axis = np.cross(a, helper)
        return axis_angle(axis / np.linalg.norm(axis), math.pi)
    return axis_angle(axis / sin, math.atan2(sin, cos))


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation (3, 3) by `angle` radians about unit `axis`."""
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def irradiance(residual: np.ndarray, lights: list[DistantLight], rotation: np.ndarray, normal: np.ndarray = FACING,
               fill: float = 1.0) -> np.ndarray:
    """RGB irradiance (3,) on a surface with `normal` (world) under the map turned by `rotation`, before strength."""
    directions, solid_angle = pixel_directions(*residual.shape[:2])
    cosine = np.maximum(directions @ (rotation.T @ normal), 0.0)  # n . (R e) = (R^T n) . e
    total = fill * np.einsum("hwc,hw->c", np.asarray(residual, np.float64), cosine * solid_angle)
    for light in lights:
        total = total + np.asarray(light.irradiance) * max(float((rotation @ light.direction) @ normal), 0.0)
    return total


def key_light(residual: np.ndarray, lights: list[DistantLight]) -> np.ndarray:
    """Direction (3,) of the strongest light of the map: its brightest lifted light, else its brightest pixel."""
    if lights:
        return max(lights, key=lambda light: float(light.irradiance @ LUMINANCE)).direction
    directions, _ = pixel_directions(*residual.shape[:2])
    brightest = np.unravel_index(np.argmax(residual @ LUMINANCE), residual.shape[:2])
    return directions[brightest]


def portrait_light(residual: np.ndarray, lights: list[DistantLight], rng: np.random.Generator,
                   key_cone: float = KEY_CONE, exposure_ev: float = EXPOSURE_EV, warm_cool: float = WARM_COOL,
                   fill_range: tuple[float, float] = FILL_RANGE, target: float = TARGET) -> PortraitLight:
    """Draw a portrait lighting of one split map (see the module docstring); finite for any map, dark ones too."""
    polar = key_cone * math.sqrt(rng.uniform())  # uniform over the cone's cap, near enough for small cones
    azimuth = rng.uniform(0.0, 2.0 * math.pi)
    towards = np.array([math.sin(polar) * math.cos(azimuth), math.sin(polar) * math.sin(azimuth), math.cos(polar)])
    rotation = axis_angle(towards, rng.uniform(0.0, 2.0 * math.pi)) @ rotation_between(key_light(residual, lights),
                                                                                      towards)
    fill = rng.uniform(*fill_range)
    falling = np.maximum(irradiance(residual, lights, rotation, FACING, fill), 1e-12)
    level = float(falling @ LUMINANCE)
    gains = level / falling  # neutral light on the face
    shift = rng.uniform(-warm_cool, warm_cool)
    gains = gains * np.array([1.0 + shift, 1.0, 1.0 - shift])
    gains = gains / float(gains @ (falling / level * LUMINANCE))  # the face's luminance unchanged by the gains
    strength = target * 2.0 ** rng.uniform(-exposure_ev, exposure_ev) / level
    return PortraitLight(rotation, float(fill), float(strength), gains)
