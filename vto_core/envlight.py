"""Split an equirectangular environment map into a low-contrast residual and a few distant lights.

Path tracing an HDRI whose light comes from a few small bright spots (sun, windows, softboxes) is noisy:
most samples miss the spots. Lifting each spot out as a distant light, sampled directly, leaves a smooth
residual map with the same total light, and renders with far less noise for the same samples.

Directions follow Blender's equirectangular convention (z up): pixel column u in [0, 1) maps to the azimuth
atan2(y, x) = pi - 2 pi u, row v in [0, 1) counted from the BOTTOM row maps to the elevation (v - 0.5) pi.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import VtoError

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True)
class DistantLight:
    """A light lifted out of a map: unit direction towards it (3,), irradiance RGB (3,) it gives a surface
    facing it, and its angular diameter in radians."""

    direction: np.ndarray
    irradiance: np.ndarray
    angle: float


def pixel_directions(height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (H, W, 3) and solid angles (H, W) of an equirectangular map's pixels, bottom row first."""
    elevation = ((np.arange(height) + 0.5) / height - 0.5) * np.pi
    azimuth = np.pi - 2 * np.pi * (np.arange(width) + 0.5) / width
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    directions = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)
    solid_angle = (2 * np.pi / width) * (np.pi / height) * np.cos(el)
    return directions, solid_angle


def label_spots(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """Connected spots of a 2-D boolean mask (4-connected), numbered 1.. in raster order of their first pixel.

    The same labels as scipy.ndimage.label with its default structure, in numpy alone (Blender's Python has no
    scipy): union-find over the mask's edges, hooking roots to the smaller index, with pointer jumping.
    """
    mask = np.asarray(mask, dtype=bool)
    height, width = mask.shape
    index = np.arange(height * width).reshape(height, width)
    across = mask[:, :-1] & mask[:, 1:]
    down = mask[:-1, :] & mask[1:, :]
    a = np.concatenate([index[:, :-1][across], index[:-1, :][down]])
    b = np.concatenate([index[:, 1:][across], index[1:, :][down]])
    parent = index.ravel().copy()
    while True:
        root_a, root_b = parent[a], parent[b]
        differ = root_a != root_b
        if not differ.any():
            break
        np.minimum.at(parent, np.maximum(root_a, root_b)[differ], np.minimum(root_a, root_b)[differ])
        while True:  # pointer jumping: every pixel points at its root
            jumped = parent[parent]
            if np.array_equal(jumped, parent):
                break
            parent = jumped
    labels = np.zeros(height * width, dtype=np.int64)
    bright = np.flatnonzero(mask.ravel())
    roots, numbers = np.unique(parent[bright], return_inverse=True)
    labels[bright] = numbers + 1
    return labels.reshape(height, width), len(roots)


def split_environment(rgb: np.ndarray, max_lights: int = 4, threshold: float = 3.0,
                      min_share: float = 0.01) -> tuple[np.ndarray, list[DistantLight], float]:
    """rgb (H, W, 3) linear radiance, bottom row first -> (residual (H, W, 3), distant lights, share dropped).

    Pixels brighter than `threshold` x the map's mean luminance form connected spots. The `max_lights` spots
    holding the most light above that level (each at least `min_share` of the map's total) become lights; every
    spot's pixels keep only the threshold level (same chromaticity). The light above the level of spots that
    did not become lights is dropped, and its share of the map's total is returned; otherwise light is
    conserved exactly (residual irradiance integral + lights = the map's).
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or min(rgb.shape[:2]) < 2:
        raise VtoError(f"environment map must be (H, W, 3), got {rgb.shape}")
    if not np.isfinite(rgb).all():
        raise VtoError("environment map holds NaN or inf")
    rgb = np.maximum(rgb, 0.0)
    directions, solid_angle = pixel_directions(*rgb.shape[:2])
    luminance = rgb @ LUMINANCE
    total = float((luminance * solid_angle).sum())
    if total <= 0.0:
        return rgb, [], 0.0
    level = threshold * total / (4 * np.pi)
    bright = luminance > level
    labels, count = label_spots(bright)
    # Light above the level, per pixel: the part a spot gives up (its chromaticity kept).
    excess = np.where(bright, 1.0 - level / np.maximum(luminance, 1e-30), 0.0)[..., None] * rgb
    weight = excess @ LUMINANCE * solid_angle
    energy = np.bincount(labels.ravel(), weights=weight.ravel(), minlength=count + 1)[1:]
    lights = []
    for index in np.argsort(energy)[::-1][:max_lights]:
        if energy[index] < min_share * total:
            break
        spot = labels == index + 1
        direction = (directions[spot] * weight[spot][:, None]).sum(axis=0)
        direction /= np.linalg.norm(direction)
        # Angular diameter: twice the light-weighted RMS angle from the centre (a sun in a bright halo stays small).
        angles = np.arccos(np.clip(directions[spot] @ direction, -1.0, 1.0))
        spread = float(np.sqrt((weight[spot] * angles**2).sum() / weight[spot].sum()))
        lights.append(DistantLight(direction, (excess[spot] * solid_angle[spot][:, None]).sum(axis=0), 2 * spread))
    residual = rgb - excess
    dropped = float(weight.sum()) - sum(float(light.irradiance @ LUMINANCE) for light in lights)
    return residual, lights, max(dropped, 0.0) / total
