"""A product on a photo, the part without Blender: the lips' and the eyelids' meshes from the face mesh, and the
composite that keeps the photo's own lips (or lids) under the product.

The renderer (blender_addon.renderers.tryon) renders the lips mesh twice under the photo's light, bare (the lips' own
shader with the photo's mean lip colour) and wearing the product. Their ratio (worn_over_bare) is what the
product does to the lips there, with the render's own shading divided out; the photo times that ratio keeps the
photo's shading, lip lines and skin-side edges. Under an opaque product the photo's own highlights are first
lowered to its lips' typical brightness (a matte product loses the shine; a glossy one brings the render's).

Shapes: images (h, w, 3) linear RGB unless said; points (K, 2) x, y in pixels; pixel (i, j) covers [j, j+1) x
[i, i+1).
"""

from __future__ import annotations

import numpy as np

from ..colour import luminance
from ..products import FaceRegion
from .lips_locator import LIP_INNER, LIP_OUTER

MESH_ROWS = 4  # rings of quads from the outer lip contour (v = 0) to the inner one (v = 1)
BULGE = 0.25  # the lips stand out of the line between their contours by this share of their thickness
FEATHER = 1  # px: the soft edge of the lips mask, inside and out (lips can be a few px thick)
HIGHLIGHT_QUANTILE = 0.7  # an opaque product lowers the photo's lips to this quantile of their brightness
RATIO_FLOOR = 1e-4  # linear: a bare render darker than this divides as if it were this
RATIO_CEILING = 64.0  # no product makes a pixel brighter than this many times the bare lips (a highlight on black)


def lips_mesh(points: np.ndarray, depth: np.ndarray | None = None, rows: int = MESH_ROWS
              ) -> tuple[np.ndarray, list[tuple[int, int, int, int]], np.ndarray]:
    """The lips as a mesh from the face mesh's (468, 2) points (and (468,) depth, nearer lower; None: flat):
    vertices (V, 3) x, y in pixels and z towards the viewer (the depth negated, plus the bulge), quads (4 indices,
    counter-clockwise as seen), and UVs (V, 2): u along the contour, v from the outer contour (0) to the inner (1),
    the group's lip-line convention."""
    points = np.asarray(points, np.float64)
    depth = np.zeros(len(points)) if depth is None else np.asarray(depth, np.float64)
    outer, inner = points[LIP_OUTER], points[LIP_INNER]
    near = -np.stack([depth[LIP_OUTER], depth[LIP_INNER]])  # (2, K): z towards the viewer
    thickness = np.linalg.norm(outer - inner, axis=1)  # (K,)
    vs = np.linspace(0.0, 1.0, rows + 1)
    columns = len(LIP_OUTER)
    vertices, uvs = [], []
    for v in vs:
        xy = outer * (1 - v) + inner * v
        z = near[0] * (1 - v) + near[1] * v + BULGE * thickness * np.sin(np.pi * v)
        vertices.append(np.column_stack([xy, z]))
        uvs.append(np.column_stack([np.arange(columns) / columns, np.full(columns, v)]))
    quads = []
    for row in range(rows):
        for col in range(columns):
            a, b = row * columns + col, row * columns + (col + 1) % columns
            quads.append((a, b, b + columns, a + columns))
    return np.concatenate(vertices), quads, np.concatenate(uvs)


LID_COLUMNS, LID_ROWS = 24, 8  # the lid mesh: columns from the outer corner to the inner, rows from lashes to brow
LID_SIDE = 2  # points of a lid loop on each side between the lash line and the brow (MediaPipe's two rings)


def resampled(points: np.ndarray, count: int) -> np.ndarray:
    """A polyline (K, D) -> (count, D) points evenly spaced along its length (its ends kept)."""
    points = np.asarray(points, np.float64)
    lengths = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1))])
    at = np.linspace(0.0, lengths[-1], count)
    if lengths[-1] <= 0:
        return np.repeat(points[:1], count, axis=0)
    return np.stack([np.interp(at, lengths, points[:, k]) for k in range(points.shape[1])], axis=1)


def lid_mesh(points: np.ndarray, depth: np.ndarray | None, region: FaceRegion, columns: int = LID_COLUMNS,
             rows: int = LID_ROWS) -> tuple[np.ndarray, list[tuple[int, int, int, int]], np.ndarray]:
    """An eyelid as a mesh from the face mesh's (468, 2) points (and (468,) depth, nearer lower; None: flat): a Coons
    patch on its loop (region.loops[0]: the lash line, the points on the eye's opening from the outer corner to the
    inner; then LID_SIDE points up the inner side, MediaPipe's rings; the brow's edge, inner to outer; LID_SIDE down the
    outer side). Vertices (V, 3) x, y in pixels and z towards the viewer, quads (wound as the lips'), UVs (V, 2): u from
    the outer end (0) to the inner (1), v from the lash line (0) to the brow (1), the eye-shadow group's lid coordinate.
    """
    points = np.asarray(points, np.float64)
    depth = np.zeros(len(points)) if depth is None else np.asarray(depth, np.float64)
    at = np.column_stack([points, -depth])  # (468, 3): z towards the viewer
    loop = list(region.loops[0])
    lash = [i for i in loop if i in region.opening]
    rest = [i for i in loop if i not in region.opening]  # inner side up, the brow's edge inner -> outer, outer side down
    inner_side = [lash[-1]] + rest[:LID_SIDE] + [rest[LID_SIDE]]
    brow = rest[LID_SIDE:len(rest) - LID_SIDE][::-1]
    outer_side = [lash[0]] + rest[len(rest) - LID_SIDE:][::-1] + [brow[0]]
    lower, upper = resampled(at[lash], columns), resampled(at[brow], columns)
    outer, inner = resampled(at[outer_side], rows + 1), resampled(at[inner_side], rows + 1)
    u = np.linspace(0.0, 1.0, columns)[None, :, None]
    v = np.linspace(0.0, 1.0, rows + 1)[:, None, None]
    corners = ((1 - u) * (1 - v) * lower[0] + u * (1 - v) * lower[-1] + (1 - u) * v * upper[0] + u * v * upper[-1])
    grid = (1 - v) * lower[None] + v * upper[None] + (1 - u) * outer[:, None] + u * inner[:, None] - corners
    vertices = grid.reshape(-1, 3)
    quads = [(row * columns + col, row * columns + col + 1, (row + 1) * columns + col + 1, (row + 1) * columns + col)
             for row in range(rows) for col in range(columns - 1)]
    # The lash line runs outer -> inner: left to right on the photo's left eye, right to left on its right eye. The
    # quads are wound as the lips' are (clockwise on the photo, whose y runs down), so each faces the viewer.
    if sum(signed_area(vertices[list(quad), :2]) for quad in quads) > 0:
        quads = [quad[::-1] for quad in quads]
    uvs = np.stack(np.broadcast_arrays(u[..., 0], v[..., 0]), axis=-1).reshape(-1, 2)
    return vertices, quads, uvs


def signed_area(polygon: np.ndarray) -> float:
    """The shoelace area of a polygon (K, 2) in image pixels: < 0 where it runs clockwise on the photo (y down)."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def feathered(mask: np.ndarray, radius: int = FEATHER) -> np.ndarray:
    """(h, w) 0/1 -> (h, w) float32 in [0, 1]: one box filter (2 * radius + 1 px) per axis, a soft edge of `radius`
    px each way; 0 where the mask has no pixel within `radius` px, 1 where all of that square is mask."""
    soft = np.asarray(mask, np.float32)
    width = 2 * radius + 1
    for axis in (0, 1):
        padded = np.pad(soft, [(radius, radius) if a == axis else (0, 0) for a in (0, 1)])
        total = np.cumsum(padded, axis=axis, dtype=np.float64)
        total = np.concatenate([np.zeros_like(np.take(total, [0], axis=axis)), total], axis=axis)
        soft = ((np.take(total, np.arange(width, total.shape[axis]), axis=axis)
                 - np.take(total, np.arange(0, total.shape[axis] - width), axis=axis)) / width).astype(np.float32)
    return np.clip(soft, 0.0, 1.0)


def worn_over_bare(bare: np.ndarray, worn: np.ndarray) -> np.ndarray:
    """What the product does to the lips: worn / bare (h, w, 3) linear renders, finite for any input (a black bare
    render divides as RATIO_FLOOR, the ratio stops at RATIO_CEILING, NaN and inf read as 0)."""
    worn = np.clip(np.nan_to_num(np.asarray(worn, np.float32), posinf=0.0), 0.0, None)
    return np.clip(worn / np.maximum(np.nan_to_num(bare), RATIO_FLOOR), 0.0, RATIO_CEILING).astype(np.float32)


def lowered_highlights(photo: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The photo (h, w, 3) linear with its lips' brightness capped at their HIGHLIGHT_QUANTILE (mask (h, w) > 0.5):
    lip lines and shading kept, shine taken down. Unchanged where the mask is empty."""
    inside = mask > 0.5
    if not inside.any():
        return photo
    brightness = luminance(photo)
    cap = np.float32(np.quantile(brightness[inside], HIGHLIGHT_QUANTILE))
    scale = np.minimum(1.0, cap / np.maximum(brightness, 1e-6))
    return photo * scale[..., None]


def composite(photo: np.ndarray, ratio: np.ndarray, mask: np.ndarray, opacity: float) -> np.ndarray:
    """The photo (h, w, 3) linear wearing the product: photo x ratio (worn_over_bare) inside the soft `mask` (h, w)
    in [0, 1], the photo's highlights lowered in proportion to `opacity`; the photo itself where the mask is 0.
    Finite for any input (the ratio kept in [0, RATIO_CEILING], NaN read as 0)."""
    photo = np.clip(np.nan_to_num(np.asarray(photo, np.float32)), 0.0, None)
    ratio = np.clip(np.nan_to_num(np.asarray(ratio, np.float32), posinf=0.0), 0.0, RATIO_CEILING)
    opacity = float(np.clip(opacity, 0.0, 1.0))
    under = photo * (1 - opacity) + lowered_highlights(photo, mask) * opacity
    soft = np.clip(np.nan_to_num(mask), 0.0, 1.0)[..., None]
    return (photo * (1 - soft) + under * ratio * soft).astype(np.float32)
