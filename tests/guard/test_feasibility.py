"""Feasibility of points, segments and trajectories: the compiled Cyrus–Beck test against exact
rational geometry, the entry point, the reasons."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from exact import mitred_offset, segment_meets_polygon
from rtctl.guard import Polygon, Scene, Zone, point_violation, segment_violation, trajectory_violation
from rtctl.guard.kernels import NO_ENTRY, clearance, segment_entry
from rtctl.trajectory import JointLimits, through_waypoints
from test_zones import SQUARE, convex

point = st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5)).map(np.array)


@settings(max_examples=80, deadline=None)
@given(convex, point, point, st.sampled_from([0.0, 0.05, 0.2]))
def test_segment_entry_agrees_with_exact_rational_geometry(vertices, a, b, m):
    scene = Scene([Zone("z", [Polygon((0, 1), vertices)])], [-5, -5], [5, 5], margin=m)
    tables = scene.tables()
    grown = mitred_offset(vertices, m)
    s, piece, _ = segment_entry(*tables, a, b, m)
    # the compiled test works on the open polygon: what it enters the closed one meets, and what
    # misses the closed one (grown by a hair, for the rounding of the unit normals) it misses
    if s < NO_ENTRY:
        assert segment_meets_polygon(a, b, mitred_offset(vertices, m + 1e-9))
        entry = a + s * (b - a)
        if s == 0.0 and clearance(*tables, a)[0] < m:
            return  # it starts inside
        assert clearance(*tables, entry)[0] == pytest.approx(m, abs=1e-9)  # on the inflated boundary
        if s > 1e-6:  # …and everything before it is outside
            before = a + np.linspace(0, s, 20)[:-1, None] * (b - a)
            assert all(clearance(*tables, x)[0] >= m - 1e-9 for x in before)
    elif not segment_meets_polygon(a, b, mitred_offset(vertices, max(m - 1e-9, 0.0))):
        pass
    else:  # the closed polygon is touched without entering the open one: only along its boundary
        assert segment_meets_polygon(a, b, grown)
        assert not segment_meets_polygon(a, b, mitred_offset(vertices, m - 1e-7) if m > 1e-7 else shrink(vertices))


def shrink(vertices):
    c = np.mean(vertices, axis=0)
    return c + (np.asarray(vertices) - c) * (1 - 1e-7)


def test_reasons_name_the_zone_and_where_the_path_enters_it():
    scene = Scene([Zone("cable carrier", [Polygon((0, 1), SQUARE)])], [-2, -2], [2, 2], margin=0.1)
    assert "inside zone 'cable carrier'" in str(point_violation(scene, [0.0, 0.0]))
    near = point_violation(scene, [0.55, 0.0])
    assert not near.inside and "within the margin of zone 'cable carrier'" in str(near)
    assert point_violation(scene, [0.55, 0.0], margin=0.0) is None
    assert "past the joint 1 limit" in str(point_violation(scene, [0.0, 2.5]))
    v = segment_violation(scene, [-1.0, 0.25], [1.0, 0.25])
    assert v.inside and v.at == pytest.approx(0.25) and np.allclose(v.q, [-0.5, 0.25])  # the zone itself
    graze = segment_violation(scene, [-1.0, 0.55], [1.0, 0.55])
    assert not graze.inside and np.allclose(graze.q, [-0.6, 0.55])  # only its margin
    assert segment_violation(scene, [-1.0, 0.65], [1.0, 0.65]) is None
    with pytest.raises(ValueError, match="2 finite joint values"):
        segment_violation(scene, [0.0], [1.0, 0.0])


def test_a_trajectory_that_bends_into_a_zone_is_caught_and_a_clear_one_certified():
    scene = Scene([Zone("z", [Polygon((0, 1), SQUARE)])], [-3, -3], [3, 3], margin=0.1)
    limits = JointLimits([1.0, 1.0], [2.0, 2.0])
    # stopping at the corner of a path around the square: straight segments, clear by the margin
    corner = [[-1.0, 0.0], [-0.65, 0.65], [0.65, 0.65], [1.0, 0.0]]
    stopping = through_waypoints(corner[1:], limits, start=corner[0])
    assert trajectory_violation(scene, stopping, 0.09, limits.v_max) is None
    # a straight move through the square is caught, with the time it first comes too close
    through = through_waypoints([[1.0, 0.0]], limits, start=[-1.0, 0.0])
    hit = trajectory_violation(scene, through, 0.05, limits.v_max)
    assert hit.what == "z" and 0 < hit.at < through.duration
    assert clearance(*scene.tables(), hit.q)[0] < 0.05 + 0.05  # within the sampling's bound
