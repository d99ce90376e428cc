"""A face region on a character's surface: each point's weight (1 inside, 0.5 on the outline, 0 outside and in the
hole past the soft edge, and where unseen) and its region coordinates."""

import numpy as np
import pytest

from vto_core.photo.surface_regions import (boundary_edges, distance_to_segments, edge_width, region_on_surface,
                                            triangles)

# A 2 x 2 grid of quads over [0, 20] x [0, 20] px, its uvs the position / 20; the centre quad's hole is none.
GRID = np.array([(x, y) for y in (0, 10, 20) for x in (0, 10, 20)], float)
QUADS = [(0, 1, 4, 3), (1, 2, 5, 4), (3, 4, 7, 6), (4, 5, 8, 7)]
UVS = GRID / 20.0


def test_uvs_are_interpolated_inside_and_the_weight_crosses_the_outline_over_the_edge():
    points = np.array([(10.0, 10.0), (5.0, 15.0), (1.0, 10.0), (19.5, 3.0), (30.0, 10.0), (-2.0, -2.0), (0.0, 5.0),
                       (-1.0, 5.0)])
    weights, uvs, distance = region_on_surface(points, np.ones(len(points), bool), GRID, QUADS, UVS, edge=4.0)
    np.testing.assert_allclose(uvs[:2], points[:2] / 20.0, atol=1e-12)  # bilinear grid: exact inside
    assert weights[0] == 1.0 and weights[1] == 1.0  # 10 and 5 px inside the outline: past the edge's inner half
    assert 0.5 < weights[3] < weights[2] < 1.0  # 0.5 and 1 px inside: on the soft edge, the deeper one higher
    assert weights[6] == pytest.approx(0.5) and 0.0 < weights[7] < 0.5  # on the outline, and 1 px outside it
    assert weights[4] == 0.0 and weights[5] == 0.0  # past the edge's outer half (2 px)
    np.testing.assert_allclose(uvs[4], (1.0, 0.5))  # outside: the nearest vertex's (20, 10)
    np.testing.assert_allclose(distance[4], 10.0)


def test_unseen_points_and_a_hole_weigh_nothing():
    ring = [(0, 1, 4, 3), (1, 2, 5, 4), (3, 4, 7, 6)]  # the grid without its top-right quad: an L
    points = np.array([(16.0, 16.0), (5.0, 5.0), (5.0, 5.0)])
    weights, _, _ = region_on_surface(points, np.array([True, True, False]), GRID, ring, UVS, edge=1.0)
    assert weights.tolist() == [0.0, 1.0, 0.0]


def test_the_outline_is_the_edges_one_quad_has():
    edges = {tuple(e) for e in boundary_edges(QUADS)}
    assert len(edges) == 8 and (1, 4) not in edges and (0, 1) in edges
    assert len(triangles(QUADS)) == 8


@pytest.mark.parametrize("points", [np.zeros((0, 2)), np.full((3, 2), 1e6)])
def test_no_points_or_far_points_are_finite(points):
    weights, uvs, distance = region_on_surface(points, np.ones(len(points), bool), GRID, QUADS, UVS, edge=2.0)
    assert weights.shape == (len(points),) and np.isfinite(uvs).all() and (weights == 0).all()


def test_a_degenerate_region_covers_nothing():
    flat = np.zeros_like(GRID)  # every vertex at one point: no triangle has an area
    weights, uvs, _ = region_on_surface(np.array([(0.0, 0.0), (3.0, 3.0)]), np.ones(2, bool), flat, QUADS, UVS, 2.0)
    assert (weights == 0).all() and np.isfinite(uvs).all()


def test_distance_to_segments_and_the_edge_floor():
    d = distance_to_segments(np.array([(0.0, 1.0), (5.0, -2.0)]), np.array([(0.0, 0.0)]), np.array([(4.0, 0.0)]))
    np.testing.assert_allclose(d, (1.0, np.hypot(1.0, 2.0)))
    assert edge_width(100.0) == pytest.approx(6.0) and edge_width(0.0) == 0.5
