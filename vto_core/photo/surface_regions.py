"""A face region on a character's surface: each vertex's weight and region coordinates, from where the vertex lands in
a front render and the region's mesh of that render's landmarks (the region meshes the photo scene uses)."""

from __future__ import annotations

import numpy as np

EDGE_SHARE = 0.06  # the weight's soft edge, across the region's outline: this share of the region's width
INSIDE_TOLERANCE = 1e-9  # barycentric slack: a point on a shared edge is inside


def triangles(quads) -> np.ndarray:
    """Quads (Q, 4) -> their triangles (2Q, 3) of vertex indices."""
    quads = np.asarray(quads, np.int64).reshape(-1, 4)
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def barycentric(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Points (N, 2) in triangles (T, 3, 2) -> their barycentric weights (N, T, 3) (NaN for a degenerate triangle)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]  # (T, 2)
    ab, ac = b - a, c - a
    det = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]  # (T,)
    det = np.where(np.abs(det) > 1e-12, det, np.nan)
    ap = points[:, None, :] - a[None]  # (N, T, 2)
    wb = (ap[..., 0] * ac[:, 1] - ap[..., 1] * ac[:, 0]) / det
    wc = (ab[:, 0] * ap[..., 1] - ab[:, 1] * ap[..., 0]) / det
    return np.stack([1.0 - wb - wc, wb, wc], axis=-1)


def boundary_edges(quads) -> np.ndarray:
    """The edges (E, 2) that only one quad has: the region's outline (and its hole's)."""
    quads = np.asarray(quads, np.int64).reshape(-1, 4)
    edges = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=-1).reshape(-1, 2), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique[counts == 1]


def distance_to_segments(points: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Each point's (N, 2) distance to the nearest of the segments (E, 2) -> (E, 2): (N,)."""
    if len(starts) == 0:
        return np.full(len(points), np.inf)
    along = ends - starts  # (E, 2)
    length2 = np.maximum((along**2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - starts[None]) * along[None]).sum(axis=-1) / length2, 0.0, 1.0)  # (N, E)
    nearest = starts[None] + t[..., None] * along[None]
    return np.sqrt(((points[:, None, :] - nearest) ** 2).sum(axis=-1)).min(axis=1)


def region_on_surface(points: np.ndarray, seen: np.ndarray, vertices: np.ndarray, quads, uvs: np.ndarray,
                      edge: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the region's mesh (vertices (V, 2) px, quads, uvs (V, 2)) covers the surface's points (N, 2) px, of which
    those `seen` (N,) bool the front render shows: (weights (N,) in [0, 1]: 0.5 on the mesh's outline (its hole's
    too), rising to 1 `edge` / 2 px inside it and falling to 0 `edge` / 2 px outside, 0 where unseen; uvs (N, 2): the
    mesh's, interpolated inside it, its nearest vertex's outside; and each point's distance (N,) px to that nearest
    vertex)."""
    points = np.asarray(points, np.float64).reshape(-1, 2)
    vertices = np.asarray(vertices, np.float64)[:, :2]
    uvs = np.asarray(uvs, np.float64)
    tris = triangles(quads)
    weights = np.zeros(len(points))
    out_uvs = np.zeros((len(points), 2))
    if len(points) == 0 or len(tris) == 0:
        return weights, out_uvs, np.full(len(points), np.inf)
    squared = ((points[:, None, :] - vertices[None]) ** 2).sum(axis=-1)  # (N, V)
    nearest = squared.argmin(axis=1)
    out_uvs[:] = uvs[nearest]
    distance = np.sqrt(squared[np.arange(len(points)), nearest])
    near = np.all((points >= vertices.min(axis=0) - edge) & (points <= vertices.max(axis=0) + edge), axis=1)
    near &= np.asarray(seen, bool)
    rows = np.flatnonzero(near)  # only the seen points in the mesh's box are looked at closely
    bary = barycentric(points[rows], vertices[tris])  # (n, T, 3)
    if len(rows) == 0 or not np.isfinite(bary).any():  # nothing to weigh, or a mesh without area
        return weights, out_uvs, distance
    inside = np.nan_to_num(bary.min(axis=-1), nan=-1.0) >= -INSIDE_TOLERANCE  # (n, T)
    covered = inside.any(axis=1)
    which = inside.argmax(axis=1)[covered]
    out_uvs[rows[covered]] = np.einsum("nk,nkd->nd", bary[covered, which], uvs[tris[which]])
    outline = boundary_edges(quads)
    depth = distance_to_segments(points[rows], vertices[outline[:, 0]], vertices[outline[:, 1]])
    ramp = np.clip((np.where(covered, depth, -depth) + edge / 2) / max(edge, 1e-6), 0.0, 1.0)
    weights[rows] = ramp * ramp * (3.0 - 2.0 * ramp)  # smoothstep: no kink where the edge meets the inside
    return weights, out_uvs, distance


def edge_width(region_width: float, share: float = EDGE_SHARE) -> float:
    """The soft edge, px, of a region `region_width` px across."""
    return max(share * float(region_width), 0.5)
