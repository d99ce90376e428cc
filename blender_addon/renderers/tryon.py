"""Render API of the lipstick on a photo: the "VTO Lipstick" group rendered onto a real portrait's lips (the paper's
AR renderer, as a photo source).

The lips are found as Match finds them (vto_core.photo.lips_locator, on the shipped face models) and framed as Match
frames them (vto_core.photo.framing.lips_view). Cycles renders the photo lips scene (scene_photo) in that frame,
bare and wearing the product, under the light read from the photo's skin; the photo times their ratio, inside the
lips' soft mask, is the try-on (vto_core.photo.tryon.composite). Every pixel outside the soft mask is the photo's.

Shapes: images (H, W, 3) display sRGB in [0, 1]; frames n x n.
"""

from __future__ import annotations

import numpy as np

from vto_core.appearance import skin_colour
from vto_core.colour import linear_to_srgb, srgb_to_linear
from vto_core.dataset import DEFAULT_SAMPLES
from vto_core.errors import VtoError
from vto_core.photo.face_reader import apply_matrix, polygon_mask, sample_bilinear
from vto_core.photo.framing import lips_view, square_view, view_cut
from vto_core.photo.lips_locator import LIP_INNER, LIP_OUTER, lips_mask
from vto_core.photo.photo_light import light_of
from vto_core.photo.tryon import composite, feathered, lips_mesh, worn_over_bare
from vto_core.specs import get_spec

from ..shipped import locate_lips
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
        lips = locate_lips(photo)
    except VtoError:
        lips = None
    if lips is None or lips.how != "face":
        raise VtoError("no face found: the lipstick is tried on the lips of a face; choose a portrait")
    outer = np.asarray(lips.outer, np.float64)
    width = float(np.linalg.norm(outer[0] - outer[len(outer) // 2]))  # LIP_OUTER runs from one corner to the other
    if width < MIN_LIPS_WIDTH:
        raise VtoError(f"no face found with lips wide enough to try on: the lips are {width:.0f} px wide, at least "
                       f"{MIN_LIPS_WIDTH} are needed; choose a larger photo or a closer portrait")
    return lips


def product_ratio(frame: np.ndarray, points: np.ndarray, depth: np.ndarray | None, mask: np.ndarray, cast: np.ndarray,
                  values: dict[str, float], samples: int, seed: int) -> np.ndarray:
    """What the product does to the lips in an n x n `frame` (display): worn / bare (n, n, 3) linear, rendered at
    most MAX_RENDER px; points (468, 2) and depth (468,) the face mesh in frame px, mask (n, n) the lips."""
    size = frame.shape[0]
    res = min(size, MAX_RENDER)
    scale = res / size
    scene = build_photo_scene()
    vertices, quads, uvs = lips_mesh(points * scale, None if depth is None else depth * scale)
    set_lips(scene, vertices, quads, uvs, res)
    inside = mask > 0.5
    albedo = srgb_to_linear(frame[inside]).mean(axis=0) / cast if inside.any() else np.full(3, 0.2)
    skin = skin_colour(frame, mask)
    set_light_and_lips(scene, cast, albedo, (albedo if skin is None else skin) / cast)
    configure_cycles(scene, res, samples, seed)
    renders = []
    for opacity in (None, 0.0):
        set_lipstick_values(scene, values if opacity is None else {**values, "opacity": opacity})
        renders.append(render_passes(scene)["Combined"][..., :3])
    ratio = worn_over_bare(renders[1], renders[0])
    if res == size:
        return ratio
    centres = (np.arange(size) + 0.5) * scale
    u, v = np.meshgrid(centres, centres)
    return sample_bilinear(ratio, u, v).transpose(1, 2, 0)


def tryon_lipstick(photo: np.ndarray, values: dict[str, float], crop: int | None = None,
                   samples: int = DEFAULT_SAMPLES, seed: int = 0) -> np.ndarray:
    """R(X, g) on a real photo: (H, W, 3) display wearing the lipstick `values`, or, with `crop` = n, the lips
    framed as Match frames them at n x n px. VtoError for a photo without a face, or lips too small."""
    values = get_spec("lipstick").check_values(values)
    photo = np.clip(np.nan_to_num(np.asarray(photo, np.float32)), 0.0, 1.0)
    lips = find_lips(photo)
    cast = light_of(photo, lips.mask).cast
    view, size, _ = lips_view(lips)
    n = crop or min(size, MAX_RENDER * 2)
    view = view.copy()
    view[:, :2] *= size / n  # the same frame seen at n x n
    to_frame = np.linalg.inv(np.vstack([view, [0.0, 0.0, 1.0]]))[:2]
    points = apply_matrix(to_frame, lips.landmarks.astype(np.float64))
    photo_scale = np.sqrt(abs(np.linalg.det(view[:, :2])))  # photo px per frame px
    depth = None if lips.depth is None else lips.depth / photo_scale
    frame = view_cut(photo, view, n)
    frame_mask, _ = lips_mask(points[LIP_OUTER], points[LIP_INNER], n, n)
    ratio = product_ratio(frame, points, depth, frame_mask, cast, values, samples, seed)
    if crop:
        worn = composite(srgb_to_linear(frame), ratio, feathered(frame_mask), values["opacity"])
        return np.clip(linear_to_srgb(worn), 0.0, 1.0).astype(np.float32)
    return on_photo(photo, lips, to_frame, ratio, values["opacity"])


def around_lips(lips, size: int) -> np.ndarray:
    """The view (2, 3) of a size x size square on the photo's found lips and around them (2.2 lips widths across,
    upright): what the previews show of a photo."""
    outer = np.asarray(lips.outer, np.float64)
    view, side = square_view((outer.min(axis=0) + outer.max(axis=0)) / 2, 2.2 * float(np.ptp(outer[:, 0])), 0.0)
    view[:, :2] *= side / size
    return view


def on_photo(photo: np.ndarray, lips, to_frame: np.ndarray, ratio: np.ndarray, opacity: float) -> np.ndarray:
    """The photo with the frame's product ratio (n, n, 3) applied inside its lips' soft mask (to_frame (2, 3): photo
    pixels to the frame's); every other pixel is the photo's own, unchanged."""
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
    out = photo.copy()
    out[y0:y1, x0:x1][soft > 0] = np.clip(linear_to_srgb(worn), 0.0, 1.0)[soft > 0]
    return out
