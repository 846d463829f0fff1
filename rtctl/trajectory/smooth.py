"""Smooth motion through via points: quintic segments that pass the waypoints without stopping.

A *run* is a sequence of points starting and ending at rest. At the interior (via) points:

* velocity — the heuristic of Craig (*Introduction to Robotics*, 3rd ed., §7.3): the mean of
  the two adjacent segment slopes when they have the same sign, zero where the joint reverses
  or rests;
* acceleration — the central difference of the slopes, 2(s_k − s_{k−1})/(T_{k−1} + T_k), where
  the velocity is non-zero, zero elsewhere (so a joint that rests in a segment stays still).

Position, velocity and acceleration are continuous at every via point (C²). Both rules are
homogeneous in 1/T: scaling every duration by λ scales velocities by 1/λ and accelerations by
1/λ² — an exact time scaling, which is what lets :func:`fit_durations` end with one uniform
factor that makes the run meet the limits exactly.
"""
from __future__ import annotations

import numpy as np

from rtctl.trajectory.quintic import T_MIN, coefficients, limit_ratio, rest_to_rest_duration


def via_states(points, T):
    """Velocities and accelerations (K+1, n) at the K+1 points of a run (zero at both ends)."""
    slopes = np.diff(points, axis=0) / T[:, None]
    v = np.zeros_like(points)
    a = np.zeros_like(points)
    before, after = slopes[:-1], slopes[1:]
    same = before * after > 0.0
    v[1:-1] = np.where(same, 0.5 * (before + after), 0.0)
    a[1:-1] = np.where(same, 2.0 * (after - before) / (T[:-1] + T[1:])[:, None], 0.0)
    return v, a


def run_coefficients(points, T):
    """(K, n, 6) coefficients of the run's segments for durations ``T`` (K,)."""
    v, a = via_states(points, T)
    return coefficients(points[:-1], v[:-1], a[:-1], points[1:], v[1:], a[1:], T[:, None])


def _ratios(points, T, v_max, a_max):
    c = run_coefficients(points, T)
    return np.array([limit_ratio(c[k], T[k], v_max, a_max) for k in range(len(T))])


def fit_durations(points, v_max, a_max, iterations: int = 20) -> np.ndarray:
    """Segment durations (K,) with which the run just meets the velocity/acceleration limits.

    Each segment starts at its rest-to-rest minimum and is shrunk or stretched by its own
    limit ratio (:func:`~rtctl.trajectory.quintic.limit_ratio`) a few times — changing one
    duration moves its neighbours' via states, so this only approaches a fit; a final
    uniform time scaling by the largest ratio then makes it exact.
    """
    T = np.array([rest_to_rest_duration(points[k + 1] - points[k], v_max, a_max) for k in range(len(points) - 1)])
    for _ in range(iterations):
        r = _ratios(points, T, v_max, a_max)
        if np.all(np.abs(r - 1.0) < 0.01):
            break
        T = np.maximum(T * r, T_MIN)
    return np.maximum(T * _ratios(points, T, v_max, a_max).max(), T_MIN)
