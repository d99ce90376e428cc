"""The reference image of a match: a file or an image datablock, checked, with an optional crop or mask, made ready
for a renderer: lips found and framed, hair found and a square of it cut.

Shared by `vto match`, the panel's operator (apply.py) and `vto batch`; bpy is imported only for datablocks and
Blender-relative ('//') paths.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import warnings
from dataclasses import dataclass, field

import numpy as np

from vto_core.errors import VtoError
from vto_core.imageio import as_float, orientation_of, read_image, resize, upright
from vto_core.photo.framing import (MIN_SIZE, cut, cut_read, face_roll, lips_frame, lips_view, square_view, view_box,
                                    view_cut)
from vto_core.photo.photo_light import light_of
from vto_core.products import get_product

from ..shipped import MODELS, PERSON_SEGMENTER, locate_lips, read_face

NO_FACE_LIGHT = "no face: the photo's light is kept"  # a hair photo with no face to read its light from
NO_FACE_HAIR = "no face: the whole image is read as hair"
HAIR_SQUARE_SHARE = 0.95  # the hair encoder reads the largest square of a hair mask that is this share hair
ROLL_NOTE = math.radians(10)  # from this roll on, the panel says the face was read upright


def absolute_path(path: str) -> str:
    """A Blender-relative path ('//x') made absolute against the open .blend; others as they are."""
    if path.startswith("//"):
        import bpy

        return bpy.path.abspath(path)
    return os.path.expanduser(path)


def load_reference(image_path: str) -> np.ndarray:
    """The reference image (H, W, 3), NaN-free and clipped to [0, 1]; one-line errors for what cannot serve.

    A few NaN or infinite pixels (an EXR from a bad render) are read as 0 or 1 with a warning; all of them is an error.
    The last file read is kept (by path, modification time and size), so a second Match on the same photo does not
    decode it again; each call gets its own copy. An 8- or 16-bit file is kept as its integers (a quarter or a half of
    the float copy's memory: 192 MB for a 64-megapixel JPEG, where float32 takes 768 MB).
    """
    if not os.path.isfile(image_path):
        raise VtoError(f"no image at {image_path}")
    stat = os.stat(image_path)
    reference, bad = _decoded_reference(image_path, stat.st_mtime_ns, stat.st_size)
    if bad:
        warnings.warn(f"{image_path}: {bad} NaN or infinite pixel(s) read as 0 (NaN, -inf) or 1 (+inf)", stacklevel=2)
    return reference.copy() if reference.dtype == np.float32 else as_float(reference)


@functools.lru_cache(maxsize=1)
def _decoded_reference(image_path: str, mtime_ns: int, size: int) -> tuple[np.ndarray, int]:
    """load_reference's work for one version of a file: (the image, read-only: an 8- or 16-bit file's integers, else
    float32 cleaned; its count of non-finite pixels)."""
    reference, _ = read_image(image_path, stored=True)
    if reference.shape[0] < MIN_SIZE or reference.shape[1] < MIN_SIZE:
        raise VtoError(f"{image_path}: image is {reference.shape[1]}x{reference.shape[0]}; at least {MIN_SIZE}x{MIN_SIZE} "
                       "is needed")
    bad = 0
    if reference.dtype == np.float32:  # integers are finite and, as floats, in [0, 1]
        bad = int((~np.isfinite(reference)).any(axis=-1).sum())
        if bad == reference.shape[0] * reference.shape[1]:
            raise VtoError(f"{image_path}: every pixel is NaN or infinite; nothing to estimate from")
        np.nan_to_num(reference, copy=False, nan=0.0, posinf=1.0, neginf=0.0)  # the array read is this function's own
        np.clip(reference, 0.0, 1.0, out=reference)
    reference.flags.writeable = False
    return reference, bad


def at_size(image: np.ndarray, height: int, width: int) -> np.ndarray:
    """(H, W, 3) -> (height, width, 3), unchanged when it already fits."""
    return image if image.shape[:2] == (height, width) else resize(image, height, width)


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
    return _checked(np.ascontiguousarray(rgb, dtype=np.float32), f"image '{image.name}'")


def _checked(image: np.ndarray, what: str) -> np.ndarray:
    if image.shape[0] < MIN_SIZE or image.shape[1] < MIN_SIZE:
        raise VtoError(f"{what}: image is {image.shape[1]}x{image.shape[0]}; at least {MIN_SIZE}x{MIN_SIZE} is needed")
    return np.clip(np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)


def crop_box(crop, width: int, height: int) -> tuple[int, int, int, int]:
    """(x, y, w, h) from the top-left, in pixels or (all four <= 1) fractions -> pixel box inside the image."""
    values = [float(v) for v in crop]
    if len(values) != 4 or not all(math.isfinite(v) for v in values):
        raise VtoError(f"a crop is four finite numbers x, y, w, h, got {tuple(crop)}")
    if all(0.0 <= v <= 1.0 for v in values):
        values = [values[0] * width, values[1] * height, values[2] * width, values[3] * height]
    x, y, w, h = (int(round(v)) for v in values)
    if x < 0 or y < 0 or w < MIN_SIZE or h < MIN_SIZE or x + w > width or y + h > height:
        raise VtoError(f"crop x={x}, y={y}, w={w}, h={h} px does not fit the {width}x{height} image with at least "
                       f"{MIN_SIZE}x{MIN_SIZE} px inside it")
    return x, y, w, h


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


@dataclass
class Reference:
    """A reference made ready for a renderer: what the encoder reads, and the region the material covers.

    image: (H, W, 3) what the encoder reads (lips framed as the default scene frames them; a square of hair).
    region: (rgb (h, w, 3), mask (h, w)) the pixels of the lips or hair, for a fit of their colour statistics
    (blender_addon.matching.photo_fit); None when unknown. lips: what the lips locator found, in the coordinates of
    `whole` (or None); hair: what the hair locator found (or None). box: (x, y, w, h) of `image` inside `whole`. notes:
    what the user should be told. light: the photo's light (vto_core.photo.photo_light.PhotoLight) that was taken out
    of `image` and `region`, or None where the photo was read as it is (`whole` is always as given).
    """

    image: np.ndarray
    region: tuple[np.ndarray, np.ndarray] | None
    whole: np.ndarray
    box: tuple[int, int, int, int]
    lips: object = None
    notes: list[str] = field(default_factory=list)
    light: object = None
    hair: object = None  # vto_core.photo.hair_locator.HairFound where the hair was found in a portrait
    turn: float = 0.0  # radians, clockwise: how far `image` is turned from the photo (the face's roll), 0 on the grid


def locate_hair(image: np.ndarray, face, light=None):
    """vto_core.photo.hair_locator.HairFound: the hair of `face`'s person in (H, W, 3), with the shipped person model,
    its colours read with the photo's `light` taken out (None: as they are); VtoError 'no hair found ...' where there is
    none."""
    from vto_core.photo.hair_locator import cached_hair_locator

    return cached_hair_locator(MODELS / PERSON_SEGMENTER).locate(image, face, light)


def turn_note(angle: float) -> list[str]:
    """[a note that the face was read upright] where it is turned by ROLL_NOTE or more, else []."""
    return [f"face turned {math.degrees(angle):+.0f} degrees: read upright"] if abs(angle) >= ROLL_NOTE else []


def in_whole(lips, box: tuple[int, int, int, int], shape: tuple[int, int]):
    """Lips found inside `box` (x, y, w, h) of an image of `shape` (H, W), in that image's coordinates."""
    import dataclasses

    x, y, w, h = box
    if (x, y, w, h) == (0, 0, shape[1], shape[0]):
        return lips
    mask = np.zeros(shape, np.float32)
    mask[y:y + h, x:x + w] = lips.mask
    offset = np.array([x, y], np.float32)
    lx, ly, lw, lh = lips.box
    landmarks = None if lips.landmarks is None else np.asarray(lips.landmarks) + offset
    return dataclasses.replace(lips, mask=mask, box=(lx + x, ly + y, lw, lh), outer=np.asarray(lips.outer) + offset,
                               inner=np.asarray(lips.inner) + offset, landmarks=landmarks)


def refuse_monochrome(whole: np.ndarray, product: str, toned: bool = True, facts: dict | None = None) -> None:
    """VtoError (one line) where the photo (H, W, 3) has no colour to read a `product` colour from: black and white,
    or (toned) a monochrome toned print (vto_core.photo.monochrome); the answer kept with the photo (its photo_facts,
    `facts` where the caller has them)."""
    from vto_core.photo.monochrome import monochrome_problem

    facts = photo_facts(whole) if facts is None else facts
    if ("monochrome", product, toned) not in facts:
        facts["monochrome", product, toned] = monochrome_problem(whole, product, toned)
    if facts["monochrome", product, toned]:
        raise VtoError(facts["monochrome", product, toned])


def photo_facts(whole: np.ndarray) -> dict:
    """What was read of the last photo, kept by a hash of its pixels (a few ms a megapixel, where reading its face
    takes 25-50): its face ('face'), its monochrome checks, its hair. The panel's thumbnail reads the photo when it
    is chosen, and each Match on it then reads nothing again."""
    key = (whole.shape, whole.dtype.str, hashlib.blake2b(np.ascontiguousarray(whole).view(np.uint8),
                                                         digest_size=16).digest())
    if _LAST_FOUND.get("key") != key:
        _LAST_FOUND.clear()
        _LAST_FOUND["key"] = key
    return _LAST_FOUND


def face_of(whole: np.ndarray, facts: dict | None = None):
    """The largest face of the photo (H, W, 3) (read_face, or None), read once per photo (its photo_facts, `facts`
    where the caller has them)."""
    facts = photo_facts(whole) if facts is None else facts
    if "face" not in facts:
        facts["face"] = read_face(whole)
    return facts["face"]


def lips_reference(whole: np.ndarray, crop=None, mask: np.ndarray | None = None, find_lips: bool = True,
                   neutral_light: bool = True) -> Reference:
    """The lips of a photo, framed for the encoder: a crop, a mask (framed by lips_frame), or, with neither, the lips
    the locator finds (framed likewise). find_lips=False takes the whole image (or the crop) as it is. A crop in which
    the locator finds no lips is taken as the artist drew it: the lips where the default scene frames them.
    neutral_light: where the lips are known, the photo's light is read from the skin beside them and taken out
    (vto_core.photo.photo_light), so the estimate is of the product, not of the light it was photographed in."""
    facts = photo_facts(whole)
    refuse_monochrome(whole, "lipstick", facts=facts)
    height, width = whole.shape[:2]
    box = crop_box(crop, width, height) if crop is not None else (0, 0, width, height)
    notes, lips = [], None
    if mask is None and find_lips:
        try:
            face = face_of(whole, facts) if crop is None else None
            lips = locate_lips(cut(whole, box), face)
        except VtoError:
            if crop is None:
                raise
            from vto_core.photo.lips_locator import DEFAULT_LENS, close_up

            lips = close_up((box[3], box[2]), DEFAULT_LENS, 0.0, "no lips found in the crop: the crop is taken as the "
                            "lips, framed as the default scene frames them")
        lips = in_whole(lips, box, (height, width))
        mask = lips.mask
        notes += [lips.note] if lips.note else []
    light = None
    if neutral_light and mask is not None:
        light = light_of(whole, mask)
        notes.append(light.describe())
    if crop is None and lips is not None:
        view, size, turn = lips_view(lips)
        if turn:  # a tilted head: the lips framed along the face's own axes, turned upright
            image = view_cut(whole, view, size, light)
            lips_mask = (view_cut(mask, view, size)[..., 0] > 0.5).astype(np.float32)
            return Reference(image, (image, lips_mask), whole, view_box(view, size, mask.shape), lips,
                             notes + turn_note(turn), light, turn=turn)
        box = (int(view[0, 2]), int(view[1, 2]), size, size)  # lips_frame of the lips found
    elif crop is None and mask is not None:
        box = lips_frame(mask)
    image = cut_read(whole, box, light)
    region = None if mask is None else (image, cut(mask, box))
    return Reference(image, region, whole, box, lips, notes, light)


def face_and_hair(whole: np.ndarray, find_hair: bool, neutral_light: bool, facts: dict | None = None
                  ) -> tuple[object, object, object]:
    """(the largest face of `whole` or None, the photo's light read beside its lips or None, the hair found around
    it or None): read_face; with neutral_light and a face, light_of the skin beside the lips; with find_hair and a
    face, locate_hair in that light (VtoError 'no hair found ...'). The last photo's face and hair are kept, by a hash
    of its pixels: the panel's thumbnail finds the hair when the photo is chosen, and Match then reads it again at no
    cost."""
    facts = photo_facts(whole) if facts is None else facts
    face, light, hair = face_of(whole, facts), None, None
    if neutral_light and face is not None:
        try:
            light = light_of(whole, locate_lips(whole, face).mask)
        except VtoError:  # a face too small for its lips to cover a pixel: no skin beside them to read
            light = None
    if find_hair and face is not None:
        light_key = None if light is None else tuple(light.gains)
        if facts.get("hair", (False,))[0] != light_key:
            facts["hair"] = (light_key, locate_hair(whole, face, light))
        hair = facts["hair"][1]
    return face, light, hair


_LAST_FOUND: dict = {}


def hair_reference(whole: np.ndarray, crop=None, mask: np.ndarray | None = None,
                   neutral_light: bool = True, find_hair: bool = True) -> Reference:
    """Hair as the hair encoder reads it: the largest square of the hair (vto_core.hair.hair_square); the region is
    all of the hair, for the fits. The hair is a mask where one is given, else the crop (all hair), else (find_hair)
    the hair found around the largest face of a portrait; a picture with no face is read whole as a patch of hair,
    unless it cannot be one (blank, noise, not a hair colour: VtoError 'no hair found ...'). find_hair=False takes
    the whole image as hair.
    neutral_light: where the whole photo shows a face, its light is read from the skin beside the lips and taken
    out (a hair colour is the hair's under neutral light); a photo without one (a patch of hair) is read as it is."""
    from vto_core.hair import hair_square
    from vto_core.photo.hair_locator import patch_problem

    facts = photo_facts(whole)
    refuse_monochrome(whole, "hair", toned=False, facts=facts)
    height, width = whole.shape[:2]
    box = crop_box(crop, width, height) if crop is not None else (0, 0, width, height)
    finding = find_hair and crop is None and mask is None
    if (neutral_light or finding) and face_of(whole, facts) is not None:
        refuse_monochrome(whole, "hair", facts=facts)  # a portrait: a toned print too (grey hair alone is near one hue)
    face, light, hair = face_and_hair(whole, finding, neutral_light, facts) if neutral_light or finding else (None,) * 3
    notes = []
    if finding:
        if face is None:
            problem = patch_problem(whole)
            if problem:
                raise VtoError(problem)
            notes.append(NO_FACE_HAIR)
        else:
            mask, box = hair.mask, hair.box
            notes += [hair.note] if hair.note else []
            notes.append(f"hair found: {hair.mask.mean():.0%} of the photo")
    if neutral_light:
        notes.append(NO_FACE_LIGHT if light is None else light.describe())
    turn = face_roll(face.landmarks) if finding and face is not None else 0.0
    if turn:  # a tilted head: the hair's region turned upright, so the square is read as an upright head shows it
        x, y, w, h = box
        view, size = square_view(np.array([x + w / 2, y + h / 2]), math.hypot(w, h), turn)
        rgb, box = view_cut(whole, view, size, light), view_box(view, size, whole.shape[:2])
        mask = (view_cut(mask, view, size)[..., 0] > 0.5).astype(np.float32)
        notes += turn_note(turn)
    else:
        rgb = cut_read(whole, box, light)
        mask = np.ones(rgb.shape[:2], np.float32) if mask is None else cut(mask, box)
    if not mask.any():
        raise VtoError("the hair mask holds no hair inside the crop")
    square = hair_square(mask, HAIR_SQUARE_SHARE)
    if square is None:
        raise VtoError(f"the hair mask holds no {MIN_SIZE}x{MIN_SIZE} px square of hair for the encoder to read: "
                       "paint more of the hair, or crop a patch of it")
    x, y, side = square
    inner = box if turn else (box[0] + x, box[1] + y, side, side)
    return Reference(cut(rgb, (x, y, side, side)), (rgb, mask), whole, inner, notes=notes, light=light, hair=hair,
                     turn=turn)


def read_reference(renderer: str, settings: dict) -> Reference:
    """The settings' reference made ready for product `renderer` (image, crop, mask, find_region: whether to find its
    region, the lips or the hair); one-line errors."""
    whole = read_image_setting(settings)
    mask = read_mask(settings["mask_path"], whole.shape[:2]) if settings.get("mask_path") else None
    product = get_product(renderer)
    return region_reference(product, whole, settings.get("crop"), mask, settings.get("find_region", True),
                            settings.get("neutral_light", True))


def region_reference(product, whole: np.ndarray, crop=None, mask: np.ndarray | None = None, find: bool = True,
                     neutral_light: bool = True) -> Reference:
    """`whole` (H, W, 3) made ready for `product`: its face-mesh region (the lips) found and framed, or, for a product
    with no face-mesh region, the hair found and a square of it cut; one-line errors."""
    if product.face_region is None:
        return hair_reference(whole, crop, mask, neutral_light, find)
    return lips_reference(whole, crop, mask, find, neutral_light)
