"""The Blender side of a match's reference: a file (a '//' path made absolute against the .blend) or an image datablock,
and a mask image, read from the settings and handed to the photo reader (vto_core.photo.photo_reader) with the shipped
face models; bpy is imported only for datablocks and Blender-relative paths.
"""

from __future__ import annotations

import os

import numpy as np

from vto_core.errors import VtoError
from vto_core.imageio import orientation_of, read_image, resize, upright
from vto_core.photo.photo_reader import Reference, checked_pixels, load_reference
from vto_core.products import get_product

from ..shipped import photo_reader


def absolute_path(path: str) -> str:
    """A Blender-relative path ('//x') made absolute against the open .blend; others as they are."""
    if path.startswith("//"):
        import bpy

        return bpy.path.abspath(path)
    return os.path.expanduser(path)


def datablock_pixels(image) -> np.ndarray:
    """A bpy image datablock as display values (H, W, 3), top row first.

    Read from its file when it has an unmodified one on disk (as a file reference would be); else from its pixels:
    byte images hold display values already, float images scene-linear ones (converted to sRGB). Either way turned
    as a viewer shows it: Blender keeps a file's pixels as stored, so its EXIF orientation is applied here.
    """
    path = absolute_path(image.filepath_raw) if image.filepath_raw else ""
    if path and os.path.isfile(path) and image.packed_file is None and not image.is_dirty:
        return load_reference(path)
    width, height = image.size
    channels = image.channels
    if width * height == 0 or channels < 1:
        raise VtoError(f"image '{image.name}' has no pixels (is its file missing?)")
    flat = np.empty(width * height * channels, np.float32)
    image.pixels.foreach_get(flat)
    pixels = np.flipud(flat.reshape(height, width, channels))
    rgb = np.repeat(pixels[..., :1], 3, axis=2) if channels < 3 else pixels[..., :3]
    if image.is_float:
        from vto_core.colour import linear_to_srgb

        rgb = linear_to_srgb(np.clip(np.nan_to_num(rgb, nan=0.0), 0.0, None))
    if path and os.path.isfile(path):
        rgb = upright(rgb, orientation_of(path))
    return checked_pixels(np.ascontiguousarray(rgb, dtype=np.float32), f"image '{image.name}'")


def read_mask(path: str, shape: tuple[int, int]) -> np.ndarray:
    """A mask image (its mean over channels > 0.5 is the region) as (H, W) float32 0/1, resized to `shape`."""
    path = absolute_path(path)
    if not os.path.isfile(path):
        raise VtoError(f"no mask image at {path}")
    rgb, _ = read_image(path)
    mask = np.nan_to_num(rgb.mean(axis=-1), nan=0.0)
    if mask.shape != shape:
        mask = resize(mask, *shape)
    mask = (mask > 0.5).astype(np.float32)
    if not mask.any():
        raise VtoError(f"mask {path} is empty: no pixel above 0.5")
    return mask


def read_image_setting(settings: dict) -> np.ndarray:
    """The reference the settings name (a file, or an image datablock), whole: (H, W, 3) in [0, 1]."""
    if settings.get("image_path"):
        return load_reference(absolute_path(settings["image_path"]))
    if settings.get("image_name"):
        import bpy

        image = bpy.data.images.get(settings["image_name"])
        if image is None:
            raise VtoError(f"no image '{settings['image_name']}' in this .blend")
        return datablock_pixels(image)
    raise VtoError("no reference image: choose a file or an image of this .blend")


def read_reference(renderer: str, settings: dict) -> Reference:
    """The settings' reference made ready for product `renderer` (image, crop, mask, find_region: whether to find its
    region, the lips or the hair); one-line errors."""
    whole = read_image_setting(settings)
    mask = read_mask(settings["mask_path"], whole.shape[:2]) if settings.get("mask_path") else None
    product = get_product(renderer)
    return photo_reader().region_reference(product, whole, settings.get("crop"), mask,
                                           settings.get("find_region", True), settings.get("neutral_light", True))
