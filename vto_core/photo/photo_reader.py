"""A photo made ready for a product, numpy only: read (checked, cleaned), cropped or masked, its face read, its region
found (the lips, by the face mesh; the hair, around the face) and framed as the product's default scene frames it, its
light read and taken out; one-line errors for what cannot serve. Match, apply, batch, eval and the datasets share it
through the add-on's reader of the shipped face models (blender_addon.shipped.photo_reader); the Blender side of a
reference (a datablock's pixels, a '//' path) is blender_addon.matching.reference.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import VtoError
from ..imageio import as_float, read_image, resize
from ..products import LIPS, FaceRegion
from .face_reader import cached_reader
from .framing import (MIN_SIZE, cut, cut_read, face_roll, region_frame, region_view, square_view, view_box,
                      view_cut)
from .photo_light import light_of

NO_FACE_LIGHT = "no face: the photo's light is kept"  # a hair photo with no face to read its light from
NO_FACE_HAIR = "no face: the whole image is read as hair"
HAIR_SQUARE_SHARE = 0.95  # the hair encoder reads the largest square of a hair mask that is this share hair
ROLL_NOTE = math.radians(10)  # from this roll on, the panel says the face was read upright


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
        raise VtoError(f"{image_path}: image is {reference.shape[1]}x{reference.shape[0]}; at least "
                       f"{MIN_SIZE}x{MIN_SIZE} is needed")
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


def checked_pixels(image: np.ndarray, what: str) -> np.ndarray:
    """`image` (H, W, 3) with non-finite values read as 0 or 1 and clipped to [0, 1]; VtoError where it is smaller
    than MIN_SIZE (`what` names it)."""
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


@dataclass
class Reference:
    """A reference made ready for a renderer: what the encoder reads, and the region the material covers.

    image: (H, W, 3) what the encoder reads (a face region, the lips or a lid, framed as the default scene frames it;
    a square of hair). region: (rgb (h, w, 3), mask (h, w)) the pixels of the face region or hair, for a fit of their
    colour statistics (blender_addon.matching.photo_fit); None when unknown. found: the face region found (RegionFound:
    the lips, the first lid), in the coordinates of `whole` (or None); hair: what the hair locator found (or None).
    box: (x, y, w, h) of `image` inside `whole`. notes: what the user should be told. light: the photo's light
    (vto_core.photo.photo_light.PhotoLight) that was taken out of `image` and `region`, or None where the photo was
    read as it is (`whole` is always as given).
    """

    image: np.ndarray
    region: tuple[np.ndarray, np.ndarray] | None
    whole: np.ndarray
    box: tuple[int, int, int, int]
    found: object = None
    notes: list[str] = field(default_factory=list)
    light: object = None
    hair: object = None  # vto_core.photo.hair_locator.HairFound where the hair was found in a portrait
    turn: float = 0.0  # radians, clockwise: how far `image` is turned from the photo (the face's roll), 0 on the grid
    views: list = field(default_factory=list)  # (h, w, 3) each: the product's other places (the other eye), framed alike
    regions: list = field(default_factory=list)  # [(FaceRegion, RegionFound), ...]: each region read, `found` first

    @property
    def images(self) -> list[np.ndarray]:
        """Every view the encoder reads of the product: `image`, then `views` (its estimate is their mean)."""
        return [self.image, *self.views]


def framed(whole: np.ndarray, found, region: FaceRegion, light) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, float]:
    """A found face region of `whole` (H, W, 3) framed as its default scene frames it, the photo's `light` taken out:
    (image (n, n, 3), its region mask (n, n), view (2, 3), n, turn rad); flipped left to right where the region is
    read mirrored (the other eye)."""
    view, size, turn = region_view(found, region)
    image = view_cut(whole, view, size, light)
    mask = (view_cut(found.mask, view, size)[..., 0] > 0.5).astype(np.float32)
    if region.mirrored:
        image, mask = np.ascontiguousarray(image[:, ::-1]), np.ascontiguousarray(mask[:, ::-1])
    return image, mask, view, size, turn


def by_lips_locator(region: FaceRegion) -> bool:
    """Whether `region` is read by the lips locator (vto_core.photo.lips_locator) rather than by its loops alone: a
    region whose hole opens (the mouth between the lips: the locator closes a closed mouth's gap and keeps teeth and
    opening out, and reads a close-up of lips where no face shows), its mask then the lips' own."""
    return region.hole_opens


def turn_note(angle: float) -> list[str]:
    """[a note that the face was read upright] where it is turned by ROLL_NOTE or more, else []."""
    return [f"face turned {math.degrees(angle):+.0f} degrees: read upright"] if abs(angle) >= ROLL_NOTE else []


def in_whole(found, box: tuple[int, int, int, int], shape: tuple[int, int]):
    """A face region found (RegionFound) inside `box` (x, y, w, h) of an image of `shape` (H, W), in that image's
    coordinates."""
    import dataclasses

    x, y, w, h = box
    if (x, y, w, h) == (0, 0, shape[1], shape[0]):
        return found
    mask = np.zeros(shape, np.float32)
    mask[y:y + h, x:x + w] = found.mask
    offset = np.array([x, y], np.float32)
    lx, ly, lw, lh = found.box
    landmarks = None if found.landmarks is None else np.asarray(found.landmarks) + offset
    return dataclasses.replace(found, mask=mask, box=(lx + x, ly + y, lw, lh), outer=np.asarray(found.outer) + offset,
                               inner=np.asarray(found.inner) + offset, landmarks=landmarks)


def refuse_monochrome(whole: np.ndarray, product: str, toned: bool = True, facts: dict | None = None) -> None:
    """VtoError (one line) where the photo (H, W, 3) has no colour to read a `product` colour from: black and white,
    or (toned) a monochrome toned print (vto_core.photo.monochrome); the answer kept with the photo (its photo_facts,
    `facts` where the caller has them)."""
    from vto_core.photo.monochrome import monochrome_problem

    facts = {} if facts is None else facts
    if ("monochrome", product, toned) not in facts:
        facts["monochrome", product, toned] = monochrome_problem(whole, product, toned)
    if facts["monochrome", product, toned]:
        raise VtoError(facts["monochrome", product, toned])


class PhotoReader:
    """Reads photos with one set of face models (files): the face detector and mesh, and the person segmenter. The last
    photo's face, monochrome checks and hair are kept, by a hash of its pixels (photo_facts)."""

    def __init__(self, detector: str | Path, landmarks: str | Path, segmenter: str | Path):
        self.detector, self.landmarks, self.segmenter = Path(detector), Path(landmarks), Path(segmenter)
        self.last_found: dict = {}

    def locate_lips(self, image: np.ndarray, face=None):
        """vto_core.photo.lips_locator.RegionFound of the lips in (H, W, 3), from `face` where it was read already;
        VtoError 'no lips found ...' where there are none."""
        from .lips_locator import cached_locator

        return cached_locator(self.detector, self.landmarks).locate(image, face)

    def locate_hair(self, image: np.ndarray, face, light=None):
        """vto_core.photo.hair_locator.HairFound: the hair of `face`'s person in (H, W, 3), with the reader's person
        model, its colours read with the photo's `light` taken out (None: as they are); VtoError 'no hair found ...'
        where there is none."""
        from vto_core.photo.hair_locator import cached_hair_locator

        return cached_hair_locator(self.segmenter).locate(image, face, light)

    def photo_facts(self, whole: np.ndarray) -> dict:
        """What was read of the last photo, kept by a hash of its pixels (SHA-256, which CPUs run in hardware: 9 ms for
        a 1 MP float32 photo on the 2-core machine, where BLAKE2b took 17 and reading its face takes 25-50): its face
        ('face'), its monochrome checks, its hair. The panel's thumbnail reads the photo when it is chosen, and each
        Match on it then reads nothing again."""
        key = (whole.shape, whole.dtype.str, hashlib.sha256(np.ascontiguousarray(whole).view(np.uint8)).digest())
        if self.last_found.get("key") != key:
            self.last_found.clear()
            self.last_found["key"] = key
        return self.last_found

    def face_of(self, whole: np.ndarray, facts: dict | None = None):
        """The largest face of the photo (H, W, 3) (FaceReader.read, or None), read once per photo (its photo_facts,
        `facts` where the caller has them)."""
        facts = self.photo_facts(whole) if facts is None else facts
        if "face" not in facts:
            facts["face"] = cached_reader(self.detector, self.landmarks).read(whole)
        return facts["face"]

    def locate_region(self, region: FaceRegion, image: np.ndarray, face=None):
        """A face-mesh region of (H, W, 3) (a RegionFound: its mask, box and loops), from `face` where it was read
        already. A region whose hole opens (the lips: by_lips_locator) by the lips locator (a close-up of lips without
        a face too); any other region by its loops on the face mesh, where the photo shows it
        (face_regions.unseen_reason). VtoError 'no ... found' where there is none."""
        if by_lips_locator(region):
            return self.locate_lips(image, face)
        from .face_regions import region_mask, region_polygons, unseen_reason
        from .lips_locator import RegionFound

        face = cached_reader(self.detector, self.landmarks).read(image) if face is None else face
        if face is None:
            raise VtoError(f"no {region.name} found: no face in the image; crop the face or give a mask")
        unseen = unseen_reason(image, face.landmarks, region)
        if unseen:
            raise VtoError(f"no {region.name} found: {'they are' if region.name.endswith('s') else 'it is'} {unseen}; "
                           "choose a closer portrait that shows them, or crop one")
        polygons = region_polygons(face.landmarks, region)
        mask, box = region_mask(polygons, *image.shape[:2])
        if not box[2]:
            raise VtoError(f"no {region.name} found: the face is too small in this image (its {region.name} cover no "
                           "pixel); crop the face or give a mask")
        inner = polygons[1] if len(polygons) > 1 else np.zeros((0, 2), np.float32)
        return RegionFound(mask, box, polygons[0], inner, "face", face.faces, face.score, face.note, face.landmarks,
                           face.box, face.depth)

    def locate_regions(self, product, image: np.ndarray, face=None) -> tuple[list, list[str]]:
        """Each of `product`'s face regions (face_regions: the right eye's lid, then the left's) the photo (H, W, 3)
        shows: ([(region, RegionFound), ...] in that order, notes on those it does not show). VtoError (the first
        region's) where it shows none."""
        found, problems = [], []
        for region in product.face_regions:
            try:
                found.append((region, self.locate_region(region, image, face)))
            except VtoError as exc:
                problems.append(exc)
        if not found:
            raise problems[0]
        notes = [f"{len(problems)} of {len(product.face_regions)} {product.region} not read: "
                 f"{str(problems[0]).split(': ', 1)[-1]}"] if problems else []
        return found, notes

    def face_region_reference(self, product, whole: np.ndarray, crop=None, mask: np.ndarray | None = None,
                              find: bool = True, neutral_light: bool = True) -> Reference:
        """The face-mesh region of `product` (its face_region: the lips, an eye's lid) in a photo, framed for the
        encoder: a crop, a mask (framed by region_frame), or, with neither, the region the locator finds (framed
        likewise; a product worn in several places, each eye, is read in each: the first is `image`, the others
        `views`, each turned as the default scene shows the first). find=False takes the whole image (or the crop) as
        it is. A crop in which the locator finds no region is taken as the artist drew it: for a region the lips
        locator reads (by_lips_locator), the lips where the default scene frames them; any other as framed on it.
        neutral_light: where the region is known, the photo's light is read from the skin beside the lips (of the
        face found, else beside the region: vto_core.photo.photo_light) and taken out, so the estimate is of the
        product, not of the light it was photographed in."""
        region = product.face_region
        facts = self.photo_facts(whole)
        refuse_monochrome(whole, product.name, facts=facts)
        height, width = whole.shape[:2]
        box = crop_box(crop, width, height) if crop is not None else (0, 0, width, height)
        notes, regions = [], []
        if mask is None and find:
            try:
                face = self.face_of(whole, facts) if crop is None else None
                regions, missing = self.locate_regions(product, cut(whole, box), face)
                notes += missing
            except VtoError:
                if crop is None:
                    raise
                if by_lips_locator(region):  # a close-up of lips: the lens where the default scene frames them
                    from .lips_locator import DEFAULT_LENS, close_up

                    regions = [(region, close_up((box[3], box[2]), DEFAULT_LENS, 0.0, "no lips found in the crop: "
                                                 "the crop is taken as the lips, framed as the default scene frames "
                                                 "them"))]
                else:  # a crop of one eye: as the artist framed it
                    notes.append(f"no {region.name} found in the crop: the crop is read as framed on them")
            regions = [(where, in_whole(found, box, (height, width))) for where, found in regions]
            if regions:
                region, found = regions[0]
                mask = found.mask
                notes += [found.note] if found.note else []
        light = None
        if neutral_light and mask is not None:
            light = light_of(whole, self.light_mask(regions[0] if regions else None, mask))
            notes.append(light.describe())
        if crop is None and regions:
            views = [framed(whole, found, where, light) for where, found in regions]
            image, framed_mask, view, size, turn = views[0]
            others = [other[0] for other in views[1:]]
            if turn:  # a tilted head: the region framed along the face's own axes, turned upright
                return Reference(image, (image, framed_mask), whole, view_box(view, size, mask.shape), regions[0][1],
                                 notes + turn_note(turn), light, turn=turn, views=others, regions=regions)
            return Reference(image, (image, framed_mask), whole, (int(view[0, 2]), int(view[1, 2]), size, size),
                             regions[0][1], notes, light, views=others, regions=regions)
        if crop is None and mask is not None:
            box = region_frame(mask, region.frame_share)
        image = cut_read(whole, box, light)
        framed_region = None if mask is None else (image, cut(mask, box))
        return Reference(image, framed_region, whole, box, regions[0][1] if regions else None, notes, light,
                         regions=regions)

    @staticmethod
    def light_mask(found, mask: np.ndarray) -> np.ndarray:
        """The mask (H, W) whose skin around it the photo's light is read from: the lips of the face mesh of `found`
        ((FaceRegion, RegionFound) or None; one light for the whole face, read where the default lips scene calibrated
        it), else `mask` itself (a region the lips locator read is the lips already: by_lips_locator)."""
        if found is None or by_lips_locator(found[0]) or found[1].how != "face" or found[1].landmarks is None:
            return mask
        found = found[1]
        from .face_regions import region_mask, region_polygons

        lips_mask, box = region_mask(region_polygons(found.landmarks, LIPS), *mask.shape)
        return lips_mask if box[2] else mask

    def face_and_hair(self, whole: np.ndarray, find_hair: bool, neutral_light: bool, facts: dict | None = None
                      ) -> tuple[object, object, object]:
        """(the largest face of `whole` or None, the photo's light read beside its lips or None, the hair found around
        it or None): read_face; with neutral_light and a face, light_of the skin beside the lips; with find_hair and a
        face, locate_hair in that light (VtoError 'no hair found ...'). The last photo's face and hair are kept, by a
        hash of its pixels: the panel's thumbnail finds the hair when the photo is chosen, and Match then reads it again
        at no cost."""
        facts = self.photo_facts(whole) if facts is None else facts
        face, light, hair = self.face_of(whole, facts), None, None
        if neutral_light and face is not None:
            try:
                light = light_of(whole, self.locate_lips(whole, face).mask)
            except VtoError:  # a face too small for its lips to cover a pixel: no skin beside them to read
                light = None
        if find_hair and face is not None:
            light_key = None if light is None else tuple(light.gains)
            if facts.get("hair", (False,))[0] != light_key:
                facts["hair"] = (light_key, self.locate_hair(whole, face, light))
            hair = facts["hair"][1]
        return face, light, hair

    def hair_reference(self, whole: np.ndarray, crop=None, mask: np.ndarray | None = None,
                       neutral_light: bool = True, find_hair: bool = True) -> Reference:
        """Hair as the hair encoder reads it: the largest square of the hair (vto_core.hair.hair_square); the region is
        all of the hair, for the fits. The hair is a mask where one is given, else the crop (all hair), else (find_hair)
        the hair found around the largest face of a portrait; a picture with no face is read whole as a patch of hair,
        unless it cannot be one (blank, noise, not a hair colour: VtoError 'no hair found ...'). find_hair=False takes
        the whole image as hair. neutral_light: where the whole photo shows a face, its light is read from the skin
        beside the lips and taken out (a hair colour is the hair's under neutral light); a photo without one (a patch of
        hair) is read as it is."""
        from vto_core.hair import hair_square
        from vto_core.photo.hair_locator import patch_problem

        facts = self.photo_facts(whole)
        refuse_monochrome(whole, "hair", toned=False, facts=facts)
        height, width = whole.shape[:2]
        box = crop_box(crop, width, height) if crop is not None else (0, 0, width, height)
        finding = find_hair and crop is None and mask is None
        if (neutral_light or finding) and self.face_of(whole, facts) is not None:
            refuse_monochrome(whole, "hair", facts=facts)  # a portrait: a toned print too (grey hair is near one hue)
        face, light, hair = (self.face_and_hair(whole, finding, neutral_light, facts) if neutral_light or finding
                             else (None,) * 3)
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

    def region_reference(self, product, whole: np.ndarray, crop=None, mask: np.ndarray | None = None, find: bool = True,
                         neutral_light: bool = True) -> Reference:
        """`whole` (H, W, 3) made ready for `product`: its face-mesh regions (the lips; both eyes' lids) found and
        framed, or, for a product with no face-mesh region, the hair found and a square of it cut; one-line errors."""
        if product.face_region is None:
            return self.hair_reference(whole, crop, mask, neutral_light, find)
        return self.face_region_reference(product, whole, crop, mask, find, neutral_light)
