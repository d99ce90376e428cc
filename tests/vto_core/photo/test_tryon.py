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


def lid_points(flip: bool = False):
    """A face mesh whose right eye's lid loop is a half ring: the lash line a flat arc 40 px wide, the brow's edge an
    arc 20 px above it (mirrored left to right with flip, as a left eye is)."""
    from vto_core.products import EYELIDS

    points = np.zeros((468, 2))
    loop = list(EYELIDS.loops[0])
    lash = [i for i in loop if i in EYELIDS.opening]  # 9: outer corner (x 80) -> inner (x 120)
    rest = [i for i in loop if i not in EYELIDS.opening]  # 2 up the inner side, the brow inner -> outer, 2 down
    xs = np.linspace(80, 120, len(lash))
    points[lash] = np.column_stack([xs, 100 - 4 * np.sin(np.linspace(0, np.pi, len(lash)))])
    brow = rest[2:-2]
    points[brow] = np.column_stack([np.linspace(122, 76, len(brow)), np.full(len(brow), 78.0)])
    points[rest[:2]] = [[121, 93], [122, 86]]
    points[rest[-2:]] = [[77, 86], [78, 93]]
    if flip:
        points[:, 0] = 200 - points[:, 0]
    return points


@pytest.mark.parametrize("flip", [False, True], ids=["right eye", "left eye"])
def test_the_lid_mesh_spans_the_loop_from_lash_line_to_brow_facing_the_viewer(flip):
    from vto_core.photo.face_regions import region_mask
    from vto_core.photo.tryon import LID_COLUMNS, LID_ROWS, lid_mesh, signed_area
    from vto_core.products import EYELIDS

    points = lid_points(flip)
    vertices, quads, uvs = lid_mesh(points, np.zeros(468), EYELIDS)
    assert vertices.shape == ((LID_ROWS + 1) * LID_COLUMNS, 3) and len(quads) == LID_ROWS * (LID_COLUMNS - 1)
    areas = np.array([signed_area(vertices[list(quad), :2]) for quad in quads])
    assert (areas < 0).all()  # no fold, every quad wound as the lips' are (so it faces the camera)
    mask, _ = region_mask([points[list(EYELIDS.loops[0])]], 200, 200)
    assert abs(-areas.sum() - mask.sum()) < 0.05 * mask.sum()  # the patch covers the loop
    lash = vertices[:LID_COLUMNS, 1]
    assert np.allclose(uvs[:LID_COLUMNS, 1], 0) and np.allclose(uvs[-LID_COLUMNS:, 1], 1)  # v: lashes 0, brow 1
    assert lash.min() > 95 and np.allclose(vertices[-LID_COLUMNS:, 1], 78)  # the lash line below, the brow above
    outer_x = vertices[0, 0]
    assert (outer_x < 100) != flip and np.allclose(uvs[:LID_COLUMNS, 0], np.linspace(0, 1, LID_COLUMNS))


def test_the_lid_mesh_is_finite_on_a_collapsed_face():
    from vto_core.photo.tryon import lid_mesh
    from vto_core.products import LEFT_EYELID

    vertices, quads, uvs = lid_mesh(np.full((468, 2), 50.0), None, LEFT_EYELID)
    assert np.isfinite(vertices).all() and np.isfinite(uvs).all() and np.allclose(vertices[:, :2], 50)
