"""The panel's thumbnail of the reference: the picture, the crop, the face regions (the lips, the lids) or the hair
found outlined, in a preview collection (no file written)."""

from __future__ import annotations

import os

import numpy as np

from vto_core.errors import VtoError
from vto_core.photo.face_reader import apply_matrix
from vto_core.photo.framing import region_view
from vto_core.photo.photo_reader import crop_box, load_reference

from ..matching.reference import absolute_path, datablock_pixels, read_mask
from ..shipped import photo_reader
from .properties import find_region

SIZE = 128  # pixels of the square thumbnail
CROP_COLOUR = (1.0, 0.78, 0.1)  # the crop's outline: Blender's selection orange-yellow
LIPS_COLOUR = (0.2, 0.9, 1.0)  # a face region found (the lips, a lid): cyan, apart from any lip or lid colour
HAIR_COLOUR = (0.3, 1.0, 0.3)  # the hair found: green, apart from any hair colour
MASK_DIM = 0.35  # outside the mask, the picture at this brightness

_previews = None
_made: dict[str, tuple] = {}  # preview name -> the settings it shows


def source_key(props, product) -> tuple:
    """What the thumbnail depends on: the reference (with its file's mtime), the crop and the mask."""
    def stamp(path: str):
        path = absolute_path(path) if path else ""
        return (path, os.path.getmtime(path)) if path and os.path.isfile(path) else (path, None)

    if props.use_datablock:
        image = props.image
        source = ("datablock", image.name if image else "", image.is_dirty if image else False)
    else:
        source = ("file",) + stamp(props.image_path)
    # a face-mesh region is found inside the crop; the hair is found only in the whole photo
    finding = (find_region(props) and not props.mask_path
               and not (product.face_region is None and props.use_crop))
    return source, tuple(round(v, 4) for v in props.crop) if props.use_crop else None, stamp(props.mask_path), finding


def outline(canvas: np.ndarray, points: np.ndarray, colour, width: int = 2) -> None:
    """Draw the closed polygon `points` (K, 2) x, y in canvas pixels onto canvas (H, W, 4), `width` (1 or 2) px wide,
    in place."""
    if len(points) < 2:
        return
    ends = np.roll(points, -1, axis=0)
    steps = int(np.ceil(np.abs(ends - points).max())) + 1
    t = np.linspace(0.0, 1.0, max(steps, 2))[:, None, None]
    dots = (points[None] + t * (ends - points)[None]).reshape(-1, 2)
    for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1))[:1 if width == 1 else 4]:
        x = np.clip(np.round(dots[:, 0] - 0.5).astype(int) + dx, 0, canvas.shape[1] - 1)
        y = np.clip(np.round(dots[:, 1] - 0.5).astype(int) + dy, 0, canvas.shape[0] - 1)
        canvas[y, x, :3] = colour


def compose(reference: np.ndarray, crop, mask: np.ndarray | None, found=None, hair=None, regions=(),
            product=None) -> np.ndarray:
    """(SIZE, SIZE, 4) RGBA, top row first: the reference fitted and centred on grey, the mask dimmed, the crop drawn,
    the face regions found (`regions`: [(FaceRegion, RegionFound)], both eyes' lids; or `found` alone, a RegionFound
    of `product`'s face_region: their outer loops, and the frame the encoder reads of each) and the hair found
    (vto_core.photo.hair_locator.HairFound: its outline)."""
    from vto_core.imageio import resize

    height, width = reference.shape[:2]
    scale = SIZE / max(height, width)
    h, w = max(1, round(height * scale)), max(1, round(width * scale))
    picture = resize(reference, h, w) if (h, w) != (height, width) else reference
    if mask is not None:
        small = resize(mask[..., None].repeat(3, axis=2), h, w)[..., 0] if (h, w) != (height, width) else mask
        picture = picture * np.where(small > 0.5, 1.0, MASK_DIM)[..., None]
    canvas = np.full((SIZE, SIZE, 4), (0.16, 0.16, 0.16, 1.0), np.float32)
    top, left = (SIZE - h) // 2, (SIZE - w) // 2
    canvas[top:top + h, left:left + w, :3] = np.clip(picture, 0.0, 1.0)
    if hair is not None:
        small = resize(hair.mask[..., None].repeat(3, axis=2), h, w)[..., 0] > 0.5
        edge = small & ~(np.roll(small, 1, 0) & np.roll(small, -1, 0) & np.roll(small, 1, 1) & np.roll(small, -1, 1))
        canvas[top:top + h, left:left + w, :3][edge] = HAIR_COLOUR
    frames = []
    for region, found in list(regions) or ([(product.face_region, found)] if found is not None else []):
        # the outer loop: at thumbnail size a mouth is a few pixels, its inner one would fill it
        outline(canvas, np.asarray(found.outer, np.float64) * scale + (left, top), LIPS_COLOUR, width=1)
        if found.how == "face":  # the frame the encoder reads, turned with a tilted face, on the photo as shown
            view, size, turn = region_view(found, region)
            if turn:
                corners = apply_matrix(view, np.array([[0, 0], [size, 0], [size, size], [0, size]], np.float64))
                outline(canvas, corners * scale + (left, top), CROP_COLOUR)
            else:
                frames.append((int(view[0, 2]), int(view[1, 2]), size, size))
    for crop in ([crop] if crop is not None else []) + frames:
        x, y, cw, ch = crop_box(crop, width, height)
        x0, y0 = left + int(x * scale), top + int(y * scale)
        x1, y1 = left + min(w, round((x + cw) * scale)) - 1, top + min(h, round((y + ch) * scale)) - 1
        for edge in (np.s_[y0:y0 + 2, x0:x1 + 1], np.s_[y1 - 1:y1 + 1, x0:x1 + 1],
                     np.s_[y0:y1 + 1, x0:x0 + 2], np.s_[y0:y1 + 1, x1 - 1:x1 + 1]):
            canvas[edge][..., :3] = CROP_COLOUR
    return canvas


def reference_pixels(props) -> np.ndarray:
    """The panel's reference as (H, W, 3); VtoError when there is none or it cannot be read."""
    if props.use_datablock:
        if props.image is None:
            raise VtoError("no image chosen")
        return datablock_pixels(props.image)
    if not props.image_path:
        raise VtoError("no image chosen")
    return load_reference(absolute_path(props.image_path))


def icon(props, name: str, product) -> tuple[int, str]:
    """(the thumbnail's icon id, a note or "") or (0, why there is none); remade only when what it shows has changed.

    With Find Lips (Find Hair) on and no mask (nor, for hair, a crop), the product's face regions (the hair) are found
    as Match will find them, and outlined; the note says what the locator said (e.g. which face, or that it found
    none)."""
    key = source_key(props, product)
    if _previews is not None and _made.get(name, (None,))[0] == key:
        return _made[name][1], _made[name][2]
    try:
        reference = reference_pixels(props)
        mask = read_mask(props.mask_path, reference.shape[:2]) if props.mask_path else None
        crop = tuple(props.crop) if props.use_crop else None
        regions, hair, note = [], None, ""
        if key[-1]:
            try:  # as Match will find them
                found = photo_reader().region_reference(product, reference, crop)
                regions, hair, note = found.regions, found.hair, "; ".join(found.notes)
            except VtoError as exc:
                note = str(exc)
        rgba = compose(reference, crop, mask, hair=hair, regions=regions)
    except Exception as exc:  # VtoError, or anything a broken file raises: the thumbnail only says why
        _made[name] = (key, 0, (str(exc).splitlines() or [""])[0])
        return 0, _made[name][2]
    icon_id = preview_icon(name, rgba)
    _made[name] = (key, icon_id, note)
    return icon_id, note


def preview_icon(name: str, pixels: np.ndarray) -> int:
    """Show pixels (H, W, 3 or 4), top row first, as the panel's preview image `name`; its icon id (0 headless)."""
    global _previews
    import bpy.utils.previews

    if _previews is None:
        _previews = bpy.utils.previews.new()
    preview = _previews.get(name) or _previews.new(name)
    preview.image_size = pixels.shape[1], pixels.shape[0]
    if pixels.shape[2] == 3:
        pixels = np.concatenate([pixels, np.ones(pixels.shape[:2] + (1,), np.float32)], axis=2)
    preview.image_pixels_float.foreach_set(np.ascontiguousarray(pixels[::-1], np.float32).ravel())  # rows bottom-up
    return preview.icon_id


def unregister() -> None:
    """Free the preview collection."""
    global _previews
    if _previews is not None:
        import bpy.utils.previews

        bpy.utils.previews.remove(_previews)
        _previews = None
    _made.clear()
