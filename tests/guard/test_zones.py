"""Zones: validation, the compiled half-planes, and the margin-inflated shapes (shapely's
mitred offset against an independent construction)."""
import numpy as np
import pytest
import shapely
from hypothesis import given, settings, strategies as st

from exact import mitred_offset
from rtctl.guard import Box, Polygon, Scene, Zone
from rtctl.guard.kernels import clearance, piece_depth

SQUARE = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]


@pytest.mark.parametrize("vertices, why", [
    ([[0, 0], [2, 0], [1, 0.5], [1, 2]], "not convex"),  # a dart
    ([[0, 0], [2, 1], [0, 2], [2, 0.3], [1, 3]], "not convex"),  # edges cross
    ([[np.cos(a), np.sin(a)] for a in np.radians(np.arange(5) * 144.0)], "not convex"),  # a pentagram: turns one way twice
    ([[0, 0], [1, 1], [2, 2]], "no area"),  # collinear
    ([[0, 0], [1, 0], [1, 0], [0, 1]], "repeated vertex"),
    ([[0, 0], [1, 0]], "at least 3"),
    ([[0, 0], [1, np.nan], [0, 1]], "finite"),
])
def test_bad_polygons_are_refused_with_the_reason(vertices, why):
    with pytest.raises(ValueError, match=why):
        Polygon((0, 1), vertices)


def test_bad_boxes_zones_and_scenes_are_refused():
    with pytest.raises(ValueError, match="lo < hi"):
        Box((0,), [1.0], [1.0])
    with pytest.raises(ValueError, match="each at most once"):
        Box((0, 0), [0, 0], [1, 1])
    with pytest.raises(ValueError, match="plane of two different joints"):
        Polygon((1, 1), SQUARE)
    zone = Zone("z", [Polygon((0, 3), SQUARE)])
    with pytest.raises(ValueError, match="joint index 3 out of range"):
        Scene([zone], [-1, -1, -1], [1, 1, 1])
    with pytest.raises(ValueError, match="declared twice"):
        Scene([zone, zone], [-1] * 4, [1] * 4)
    with pytest.raises(ValueError, match="margin"):
        Scene([zone], [-1] * 4, [1] * 4, margin=-0.1)


@pytest.mark.parametrize("order", [1, -1])
def test_half_planes_point_out_of_the_polygon_whatever_its_orientation(order):
    scene = Scene([Zone("z", [Polygon((1, 0), np.array(SQUARE)[::order] + [2.0, 0.0])])], [-5, -5], [5, 5])
    rows, cols, pieces = scene.tables()
    # (q1, q0) = (2, 0) is the centre: half the side inside; 1 outside the right face
    assert piece_depth(rows, cols, 0, 4, np.array([0.0, 2.0])) == pytest.approx(-0.5)
    assert piece_depth(rows, cols, 0, 4, np.array([0.0, 3.5])) == pytest.approx(1.0)
    assert clearance(rows, cols, pieces, np.array([0.0, 3.5]))[1] == 0


def test_joint_groups_link_joints_through_zones():
    zones = [Zone("a", [Polygon((0, 1), SQUARE)]), Zone("b", [Box((1, 2), [0, 0], [1, 1])]),
             Zone("c", [Box((4,), [0], [1])])]
    groups = Scene(zones, [-2] * 5, [2] * 5).joint_groups()
    assert sorted(groups) == [((0, 1, 2), (0, 1)), ((4,), (2,))]


def _turns(v):
    """sin of the turn at each vertex, signed (a nearly straight one makes a mitre ill-conditioned)."""
    e = np.roll(v, -1, 0) - v
    f = np.roll(e, -1, 0)
    return (e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]) / (np.hypot(*e.T) * np.hypot(*f.T))


# GEOS's hull of points with a subnormal coordinate can turn the wrong way at a vertex (found:
# (0, -1), (-0.5, 1), (0, 5e-324), (1, 0)): every turn must be the same way, clearly
convex = st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=3, max_size=9).map(
    lambda p: np.asarray(shapely.MultiPoint(p).convex_hull.exterior.coords)[:-1]
    if shapely.MultiPoint(p).convex_hull.geom_type == "Polygon" else None).filter(
    lambda v: v is not None and shapely.Polygon(v).area > 0.05 and
    min(np.hypot(*(np.roll(v, -1, 0) - v).T)) > 1e-3 and (min(_turns(v)) > 1e-3 or max(_turns(v)) < -1e-3))


@settings(max_examples=40, deadline=None)
@given(convex, st.floats(0.0, 0.3), st.integers(0, 2**31 - 1))
def test_the_inflated_shape_is_the_mitred_offset_and_contains_the_euclidean_one(vertices, m, seed):
    scene = Scene([Zone("z", [Polygon((0, 1), vertices)])], [-5, -5], [5, 5], margin=m)
    shape = scene.inflated_shape(0, (0, 1), m, (-5, -5, 5, 5))
    reference = shapely.Polygon(mitred_offset(vertices, m))
    # shapely's offset equals the half-plane construction (to rounding; Hausdorff distance, since
    # an overlay of two nearly coincident polygons is what GEOS is least robust at)
    assert shapely.hausdorff_distance(shape, reference) < 1e-9
    rows, cols, pieces = scene.tables()
    pts = np.random.default_rng(seed).uniform(-1.6, 1.6, (160, 2))
    raw = shapely.Polygon(vertices)
    for x in pts:
        depth = clearance(rows, cols, pieces, x)[0]
        d = raw.distance(shapely.Point(x))
        if abs(depth - m) > 1e-9:
            assert (depth < m) == shape.contains(shapely.Point(x))  # depth < m ⇔ inside the offset
        assert depth <= d + 1e-12  # …which contains everything within m (Euclidean)
    # depth is 1-Lipschitz (what certifies sampled trajectories)
    a, b = pts[:80], pts[80:]
    da = np.array([clearance(rows, cols, pieces, x)[0] for x in a])
    db = np.array([clearance(rows, cols, pieces, x)[0] for x in b])
    assert np.all(np.abs(da - db) <= np.hypot(*(a - b).T) + 1e-12)
