"""The try-on's Blender-free half (vto_core.photo.tryon): the lips mesh from the face mesh, the soft mask, the
composite that keeps the photo under the product."""

import numpy as np
import pytest

from vto_core.photo.lips_locator import LIP_INNER, LIP_OUTER
from vto_core.photo.tryon import MESH_ROWS, composite, feathered, lips_mesh, lowered_highlights, worn_over_bare


def face_points():
    """A face mesh whose lips are an ellipse ring 60 px wide: the outer contour, and the inner one half its size."""
    points = np.zeros((468, 2))
    angles = np.linspace(0, 2 * np.pi, len(LIP_OUTER), endpoint=False)
    points[LIP_OUTER] = np.column_stack([100 + 30 * np.cos(angles), 80 + 12 * np.sin(angles)])
    points[LIP_INNER] = np.column_stack([100 + 15 * np.cos(angles), 80 + 4 * np.sin(angles)])
    return points


def test_the_lips_mesh_runs_from_the_outer_contour_to_the_inner_and_bulges_towards_the_viewer():
    vertices, quads, uvs = lips_mesh(face_points(), np.full(468, 5.0))
    rows = MESH_ROWS + 1
    assert vertices.shape == (rows * len(LIP_OUTER), 3) and len(quads) == MESH_ROWS * len(LIP_OUTER)
    assert np.allclose(vertices[:len(LIP_OUTER), :2], face_points()[LIP_OUTER])  # v = 0: the outer contour
    assert np.allclose(vertices[-len(LIP_OUTER):, :2], face_points()[LIP_INNER])  # v = 1: the inner one
    assert uvs[:, 1].min() == 0 and uvs[:, 1].max() == 1 and 0 <= uvs[:, 0].min() and uvs[:, 0].max() < 1
    middle = vertices[len(LIP_OUTER) * (rows // 2):len(LIP_OUTER) * (rows // 2 + 1), 2]
    assert np.all(middle > -5.0) and np.allclose(vertices[:len(LIP_OUTER), 2], -5.0)  # depth 5 px away, bulging
    assert max(max(q) for q in quads) < len(vertices) and np.isfinite(lips_mesh(face_points())[0]).all()


def test_the_soft_mask_reaches_one_pixel_either_way():
    mask = np.zeros((20, 20), np.float32)
    mask[5:15, 5:15] = 1
    soft = feathered(mask)
    assert soft[6:14, 6:14].min() == 1.0 and soft[3, 10] == 0 and 0 < soft[4, 10] < 1 and 0 < soft[5, 10] < 1
    assert not feathered(np.zeros((8, 8))).any()


def test_the_composite_keeps_the_photo_off_the_lips_and_where_the_product_changes_nothing():
    rng = np.random.default_rng(0)
    photo = rng.random((16, 16, 3)).astype(np.float32)
    mask = np.zeros((16, 16), np.float32)
    mask[4:12, 4:12] = 1
    ratio = np.full((16, 16, 3), 0.25, np.float32)
    worn = composite(photo, worn_over_bare(np.ones_like(ratio), ratio), mask, 0.0)
    assert np.array_equal(worn[mask == 0], photo[mask == 0])
    assert np.allclose(worn[mask == 1], photo[mask == 1] * 0.25)  # a transparent product: the photo x the ratio
    assert np.allclose(composite(photo, worn_over_bare(ratio, ratio), mask, 0.7)[mask == 0], photo[mask == 0])
    lowered = lowered_highlights(photo, mask)
    assert np.all(lowered <= photo + 1e-7) and lowered[mask == 1].max() < photo[mask == 1].max()


def test_extremes_stay_finite():
    photo = np.full((8, 8, 3), np.nan, np.float32)
    black = np.zeros((8, 8, 3), np.float32)
    out = composite(photo, worn_over_bare(black, np.full((8, 8, 3), np.inf, np.float32)), np.ones((8, 8)), 2.0)
    assert np.isfinite(out).all()
    assert np.array_equal(lowered_highlights(black, np.zeros((8, 8))), black)
    assert composite(black, worn_over_bare(black, black), np.zeros((8, 8)), -1.0) == pytest.approx(black)
