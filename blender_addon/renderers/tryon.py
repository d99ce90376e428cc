"""Render API of the lipstick on a photo: the "VTO Lipstick" group rendered onto a real portrait's lips (the paper's
AR renderer, as a photo source).

The lips are found as Match finds them (vto_core.photo.lips_locator, on the shipped face models) and framed as Match
frames them (vto_core.photo.framing.region_view). Cycles renders the photo lips scene (scene_photo) in that frame,
bare and wearing the product, under the light read from the photo's skin; the photo times their ratio, inside the
lips' soft mask, is the try-on (vto_core.photo.tryon.composite). Every pixel outside the soft mask is the photo's.

Shapes: images (H, W, 3) display sRGB in [0, 1]; frames n x n.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from vto_core.appearance import skin_colour
from vto_core.colour import linear_to_srgb, srgb_to_linear
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.photo.face_reader import apply_matrix, clean_photo, polygon_mask, sample_bilinear
from vto_core.photo.framing import region_view, square_view, view_box, view_cut
from vto_core.photo.face_regions import region_mask
from vto_core.photo.lips_locator import LIP_INNER, LIP_OUTER
from vto_core.photo.photo_light import light_of
from vto_core.photo.tryon import composite, feathered, lips_mesh, worn_over_bare
from vto_core.products import get_spec

from ..shipped import photo_reader
from .cycles import configure_cycles, render_passes
from .lipstick import set_lipstick_values
from .scene_photo import build_photo_scene, set_light_and_lips, set_lips

# px between the mouth's corners: narrower lips are too small to render onto (a product a few pixels across). The
# astronaut's, in a 512 px portrait, are 48.
MIN_LIPS_WIDTH = 40
MAX_RENDER = 160  # px: the frame is rendered at most this large; the ratio is smooth and sampled up to the photo
EDGE = 3  # px around the lips' box: more than the soft mask reaches (vto_core.photo.tryon.feathered)


def find_lips(photo: np.ndarray):
    """The lips of the largest face of (H, W, 3) (vto_core.photo.lips_locator.LipsFound); VtoError 'no face found
    ...' where there is no face, or its lips are too small to render onto."""
    try:
        lips = photo_reader().locate_lips(photo)
    except VtoError:
        lips = None
    return lips_to_render(lips)


def lips_to_render(lips):
    """`lips` (vto_core.photo.lips_locator.LipsFound, or None) where they are a face's lips wide enough to render
    onto; VtoError 'no face found ...' where not."""
    if lips is None or lips.how != "face":
        raise VtoError("no face found: the lipstick is tried on the lips of a face; choose a portrait")
    outer = np.asarray(lips.outer, np.float64)
    width = float(np.linalg.norm(outer[0] - outer[len(outer) // 2]))  # LIP_OUTER runs from one corner to the other
    if width < MIN_LIPS_WIDTH:
        raise VtoError(f"no face found with lips wide enough to try on: the lips are {width:.0f} px wide, at least "
                       f"{MIN_LIPS_WIDTH} are needed; choose a larger photo or a closer portrait")
    return lips


@dataclass
class PhotoLips:
    """A portrait's lips ready to render onto: found, framed as Match frames them at n x n px, and its light read."""

    photo: np.ndarray  # (H, W, 3) display
    lips: object  # vto_core.photo.lips_locator.LipsFound
    cast: np.ndarray  # (3,) the photo's light colour, linear gains of mean 1
    n: int
    to_frame: np.ndarray  # (2, 3) photo px -> frame px
    points: np.ndarray  # (468, 2) the face mesh in frame px
    depth: np.ndarray | None  # (468,) in frame px, nearer lower
    frame: np.ndarray  # (n, n, 3) display: what the frame sees of the photo
    mask: np.ndarray  # (n, n) the lips in the frame


def photo_lips(photo: np.ndarray, n: int | None = None, lips=None) -> PhotoLips:
    """The lips of the largest face of (H, W, 3) display (or `lips`, found in it before), framed at n x n px (None:
    the frame's own size, at most 2 x MAX_RENDER). VtoError 'no face found ...' (find_lips, lips_to_render)."""
    photo = clean_photo(photo)  # no copy of a clean photo (a 64-megapixel one is 768 MB)
    lips = find_lips(photo) if lips is None else lips_to_render(lips)
    view, size, _ = region_view(lips)
    n = n or min(size, MAX_RENDER * 2)
    view = view.copy()
    view[:, :2] *= size / n  # the same frame seen at n x n
    to_frame = np.linalg.inv(np.vstack([view, [0.0, 0.0, 1.0]]))[:2]
    points = apply_matrix(to_frame, lips.landmarks.astype(np.float64))
    photo_scale = np.sqrt(abs(np.linalg.det(view[:, :2])))  # photo px per frame px
    depth = None if lips.depth is None else lips.depth / photo_scale
    mask, _ = region_mask([points[LIP_OUTER], points[LIP_INNER]], n, n)
    return PhotoLips(photo, lips, light_of(photo, lips.mask).cast, n, to_frame, points, depth,
                     view_cut(photo, view, n), mask)


def set_photo_lips(target: PhotoLips, samples: int, seed: int) -> bpy.types.Scene:
    """The photo lips scene set to `target`'s lips, light and lip colour, rendering render_size(target) px."""
    res = render_size(target)
    scale = res / target.n
    scene = build_photo_scene()
    vertices, quads, uvs = lips_mesh(target.points * scale, None if target.depth is None else target.depth * scale)
    set_lips(scene, vertices, quads, uvs, res)
    inside = target.mask > 0.5
    albedo = (srgb_to_linear(target.frame[inside]).mean(axis=0) / target.cast if inside.any() else np.full(3, 0.2))
    skin = skin_colour(target.frame, target.mask)
    set_light_and_lips(scene, target.cast, albedo, (albedo if skin is None else skin) / target.cast)
    configure_cycles(scene, res, samples, seed)
    return scene


def render_size(target: PhotoLips) -> int:
    """px a side of the render of `target`'s frame: its n, at most MAX_RENDER."""
    return min(target.n, MAX_RENDER)


def render_look(scene: bpy.types.Scene, values: dict[str, float]) -> np.ndarray:
    """The photo lips scene (set_photo_lips) wearing `values`: (res, res, 3) linear."""
    set_lipstick_values(scene, values)
    return render_passes(scene)["Combined"][..., :3]


def product_ratio(target: PhotoLips, values: dict[str, float], samples: int, seed: int,
                  bare: np.ndarray | None = None, bare_seed: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """What the product does to `target`'s lips: (worn / bare (n, n, 3) linear, the bare render (res, res, 3)). The
    frame is rendered at render_size px, the smooth ratio sampled up to n; `bare`: a bare render of this target kept
    from before (None: rendered now, with `bare_seed`, or None: `seed`)."""
    scene = set_photo_lips(target, samples, seed if bare_seed is None else bare_seed)
    if bare is None:
        bare = render_look(scene, {**values, "opacity": 0.0})
    scene.cycles.seed = seed
    ratio = worn_over_bare(bare, render_look(scene, values))
    res, size = ratio.shape[0], target.n
    if res == size:
        return ratio, bare
    centres = (np.arange(size) + 0.5) * res / size
    u, v = np.meshgrid(centres, centres)
    return sample_bilinear(ratio, u, v).transpose(1, 2, 0), bare


def tryon_lipstick(photo: np.ndarray, values: dict[str, float], crop: int | None = None,
                   samples: int = DEFAULT_SAMPLES, seed: int = 0, in_place: bool = False) -> np.ndarray:
    """R(X, g) on a real photo: (H, W, 3) display wearing the lipstick `values`, or, with `crop` = n, the lips
    framed as Match frames them at n x n px. VtoError for a photo without a face, or lips too small. in_place: a
    clean float32 photo (in [0, 1], finite) is drawn on itself, not on a copy (a 64-megapixel photo is 778 MB)."""
    values = get_spec("lipstick").check_values(values)
    target = photo_lips(photo, crop)
    ratio, _ = product_ratio(target, values, samples, seed)
    if crop:
        worn = composite(srgb_to_linear(target.frame), ratio, feathered(target.mask), values["opacity"])
        return np.clip(linear_to_srgb(worn), 0.0, 1.0).astype(np.float32)
    return on_photo(target.photo, target.lips, target.to_frame, ratio, values["opacity"], in_place)


def around_lips(lips, size: int) -> np.ndarray:
    """The view (2, 3) of a size x size square on the photo's found lips and around them (2.2 lips widths across,
    upright): what the previews show of a photo."""
    outer = np.asarray(lips.outer, np.float64)
    view, side = square_view((outer.min(axis=0) + outer.max(axis=0)) / 2, 2.2 * float(np.ptp(outer[:, 0])), 0.0)
    view[:, :2] *= side / size
    return view


def on_photo(photo: np.ndarray, lips, to_frame: np.ndarray, ratio: np.ndarray, opacity: float,
             in_place: bool = False, window: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """The photo with the frame's product ratio (n, n, 3) applied inside its lips' soft mask (to_frame (2, 3): photo
    pixels to the frame's); every other pixel is the photo's own, unchanged. in_place: drawn on `photo` itself.
    window (x0, y0, x1, y1): only that part of the photo, drawn on a copy of it (it holds the lips' box and EDGE px
    around it): a 64-megapixel portrait costs its part, not a whole copy."""
    x, y, w, h = lips.box
    height, width = photo.shape[:2]
    x0, y0 = max(0, x - EDGE), max(0, y - EDGE)
    x1, y1 = min(width, x + w + EDGE), min(height, y + h + EDGE)
    inner = polygon_mask(np.asarray(lips.inner), x0, y0, x1 - x0, y1 - y0)
    mask = polygon_mask(np.asarray(lips.outer), x0, y0, x1 - x0, y1 - y0) & ~inner
    xs, ys = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
    u = to_frame[0, 0] * xs + to_frame[0, 1] * ys + to_frame[0, 2]
    v = to_frame[1, 0] * xs + to_frame[1, 1] * ys + to_frame[1, 2]
    local = sample_bilinear(ratio, u, v).transpose(1, 2, 0)
    soft = feathered(mask)
    worn = composite(srgb_to_linear(photo[y0:y1, x0:x1]), local, soft, opacity)
    if window is None:
        out, (left, top) = (photo if in_place else photo.copy()), (0, 0)
    else:
        left, top, right, bottom = window
        out = photo[top:bottom, left:right].copy()
    out[y0 - top:y1 - top, x0 - left:x1 - left][soft > 0] = np.clip(linear_to_srgb(worn), 0.0, 1.0)[soft > 0]
    return out


def tryon_view(photo: np.ndarray, values: dict[str, float], size: int, samples: int, seed: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """What the previews show of a lipstick tried on a portrait (H, W, 3): (the photo around its lips, the same
    square wearing `values`), each (size, size, 3), framed by around_lips: tryon_lipstick's try-on, drawn only on
    the part of the photo the square shows. VtoError 'no face found ...' where it has no face, or its lips are too
    small."""
    values = get_spec("lipstick").check_values(values)
    target = photo_lips(photo)
    ratio, _ = product_ratio(target, values, samples, seed)
    view = around_lips(target.lips, size)
    height, width = target.photo.shape[:2]
    x, y, w, h = view_box(view, size, (height, width))
    lx, ly, lw, lh = target.lips.box
    # the part of the photo that view_cut reads (a pixel more each way) and on_photo draws on (EDGE around the lips)
    x0, y0 = max(0, min(x - 1, lx - EDGE)), max(0, min(y - 1, ly - EDGE))
    x1, y1 = min(width, max(x + w + 1, lx + lw + EDGE)), min(height, max(y + h + 1, ly + lh + EDGE))
    worn = on_photo(target.photo, target.lips, target.to_frame, ratio, values["opacity"], window=(x0, y0, x1, y1))
    shifted = view.copy()
    shifted[:, 2] -= (x0, y0)
    return view_cut(target.photo, view, size), view_cut(worn, shifted, size)
