"""(O, A, T) angles about the orientation reference frame (docs/kinematics.md, eqs. 8-15)."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rtctl.model.kinematics import from_oat, to_oat

angle = st.floats(-math.pi, math.pi, allow_nan=False)
quaternion = st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 4).filter(lambda v: np.linalg.norm(v) > 1e-3)


def quaternion_matrix(v) -> np.ndarray:
    w, x, y, z = np.asarray(v) / np.linalg.norm(v)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def oat_matrix(o, a, t) -> np.ndarray:
    """R_R · Rot(y,O) Rot(x,A) Rot(z,T) multiplied out by hand (the copy's eq. 11 is garbled)."""
    cO, sO, cA, sA, cT, sT = math.cos(o), math.sin(o), math.cos(a), math.sin(a), math.cos(t), math.sin(t)
    M = np.array([[cO * cT + sO * sA * sT, -cO * sT + sO * sA * cT, sO * cA],
                  [cA * sT, cA * cT, -sA],
                  [-sO * cT + cO * sA * sT, sO * sT + cO * sA * cT, cO * cA]])
    R_R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # eq. (8)
    return R_R @ M


def wrapped(x) -> float:
    return abs(math.remainder(x, 2 * math.pi))


def test_zero_angles_give_the_reference_frame():
    np.testing.assert_array_equal(from_oat(0.0, 0.0, 0.0), [[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    assert to_oat(np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])) == (0.0, 0.0, 0.0)


@given(angle, angle, angle)
def test_from_oat_is_the_definition(o, a, t):
    np.testing.assert_allclose(from_oat(o, a, t), oat_matrix(o, a, t), atol=1e-15)


@settings(max_examples=300)
@given(quaternion)
def test_round_trip_from_any_rotation(v):
    R = quaternion_matrix(v)
    o, a, t = to_oat(R)
    assert all(-math.pi < x <= math.pi for x in (o, a, t)) and abs(a) <= math.pi / 2
    np.testing.assert_allclose(from_oat(o, a, t), R, atol=1e-12)


@settings(max_examples=300)
@given(angle, st.floats(-math.pi / 2 + 1e-6, math.pi / 2 - 1e-6), angle)
def test_angles_come_back_away_from_the_singularity(o, a, t):
    """|A| < 90°: the triple is unique and returned (to within what cos A allows)."""
    back = to_oat(from_oat(o, a, t))
    tol = 1e-15 / math.cos(a) + 1e-12
    assert wrapped(back[0] - o) < tol and abs(back[1] - a) < tol and wrapped(back[2] - t) < tol


@given(angle, st.sampled_from([math.pi / 2, -math.pi / 2]), angle)
def test_singular_case_takes_t_zero(o, a, t):
    """|A| = 90°: O and T turn about one axis; T = 0 and O carries O − T (A = 90°) or O + T."""
    R = from_oat(o, a, t)
    o2, a2, t2 = to_oat(R)
    assert t2 == 0.0 and a2 == a
    assert wrapped(o2 - (o - t if a > 0 else o + t)) < 1e-12
    np.testing.assert_allclose(from_oat(o2, a2, t2), R, atol=1e-12)


@given(angle, st.floats(1e-14, 1e-6), st.sampled_from([1.0, -1.0]), angle)
def test_round_trip_next_to_the_singularity(o, gap, side, t):
    """Where the second row of R_Rᵀ R is only rounding noise, R still comes back exactly."""
    R = from_oat(o, side * (math.pi / 2 - gap), t)
    np.testing.assert_allclose(from_oat(*to_oat(R)), R, atol=1e-12)


def test_angles_stay_in_the_half_open_range():
    o, a, t = to_oat(from_oat(math.pi, 0.3, -math.pi))
    assert o == math.pi and t == math.pi and a == 0.3
