"""Feasibility at its boundaries, against closed forms: a target exactly at the margin is
outside the (open) inflated zone, and the sampled certificate of a trajectory never passes one
that comes closer than the clearance between two samples (docs/interference_guard.md,
"Feasibility")."""
import numpy as np
import pytest

from rtctl.guard import Polygon, Scene, Zone, point_violation, segment_violation, trajectory_violation
from rtctl.trajectory import JointLimits, through_waypoints
from test_zones import SQUARE

SCENE = Scene([Zone("z", [Polygon((0, 1), SQUARE)])], [-3, -3], [3, 3], margin=0.25)


@pytest.mark.parametrize("target", [[-0.75, 0.0], [0.75, 0.25], [0.0, -0.75], [0.75, 0.75]])
def test_a_target_exactly_at_the_margin_is_feasible_and_one_a_hair_closer_is_not(target):
    # the square [-0.5, 0.5]² grown by 0.25 (mitred): every target here lies on its boundary,
    # at depth max(|x|, |y|) − 0.5 = 0.25 exactly (dyadic numbers: no rounding)
    target = np.array(target)
    assert np.max(np.abs(target)) - 0.5 == 0.25
    assert point_violation(SCENE, target) is None
    assert segment_violation(SCENE, 2 * target, target) is None  # (the segment test agrees: open zones)
    closer = target * (1 - 1e-9)
    v = point_violation(SCENE, closer)
    assert v is not None and v.what == "z" and not v.inside


def _graze(d, shift, length):
    """A straight rest-to-rest move past the corner (0.5, 0.5) of the square along the
    direction (1, −1)/√2, through its closest point (0.5 + d, 0.5 + d): the smallest depth on
    it is d exactly (depth = max(x, y) − 0.5 in that corner's region)."""
    u = np.array([1.0, -1.0]) / np.sqrt(2)
    closest = np.array([0.5 + d, 0.5 + d])
    return closest - (length + shift) * u, closest + (length - shift) * u


def test_the_trajectory_certificate_never_passes_a_path_closer_than_the_clearance():
    """200 grazing moves, each closer than the clearance by less than an eighth of it: sampling
    would pass many of them (the closest point falls between samples); the ½·step reserve of the
    certificate catches every one. Moves that keep 1.3 × the clearance are certified."""
    rng = np.random.default_rng(27)
    limits = JointLimits([1.0, 1.0], [2.0, 2.0])
    clearance = 0.1
    missed = []
    for k in range(200):
        d = clearance * rng.uniform(0.875, 1.0)
        a, b = _graze(d, rng.uniform(-0.2, 0.2), rng.uniform(0.4, 1.0))
        move = through_waypoints([b], limits, start=a)
        if trajectory_violation(SCENE, move, clearance, limits.v_max) is None:
            missed.append((k, d))
    assert not missed, f"{len(missed)} of 200 paths closer than the clearance were certified: {missed[:5]}"
    for k in range(20):
        a, b = _graze(1.3 * clearance, rng.uniform(-0.2, 0.2), rng.uniform(0.4, 1.0))
        move = through_waypoints([b], limits, start=a)
        assert trajectory_violation(SCENE, move, clearance, limits.v_max) is None
