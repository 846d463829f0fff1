"""A joint trajectory as consecutive quintic segments, sampled every tick without allocating.

Time is the loop's time base: segment k runs from ``knots[k]`` to ``knots[k+1]``. Before the
start :meth:`JointTrajectory.sample` gives the start state; after the end it holds the last
point with zero velocity and acceleration.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel
from rtctl.errors import TrajectoryError


@kernel
def _sample(knots, coeffs, t, q, qd, qdd):  # pragma: no cover - compiled
    m = coeffs.shape[0]
    at_rest = False
    if t >= knots[m]:
        seg = m - 1
        tau = knots[m] - knots[m - 1]
        at_rest = True
    elif t <= knots[0]:
        seg = 0
        tau = 0.0
    else:
        lo, hi = 0, m  # knots[lo] <= t < knots[hi]
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if knots[mid] <= t:
                lo = mid
            else:
                hi = mid
        seg = lo
        tau = t - knots[lo]
    for j in range(coeffs.shape[1]):
        c0, c1, c2, c3, c4, c5 = (coeffs[seg, j, 0], coeffs[seg, j, 1], coeffs[seg, j, 2],
                                  coeffs[seg, j, 3], coeffs[seg, j, 4], coeffs[seg, j, 5])
        q[j] = c0 + tau * (c1 + tau * (c2 + tau * (c3 + tau * (c4 + tau * c5))))
        if at_rest:
            qd[j] = 0.0
            qdd[j] = 0.0
        else:
            qd[j] = c1 + tau * (2.0 * c2 + tau * (3.0 * c3 + tau * (4.0 * c4 + tau * 5.0 * c5)))
            qdd[j] = 2.0 * c2 + tau * (6.0 * c3 + tau * (12.0 * c4 + tau * 20.0 * c5))


class JointTrajectory:
    """Piecewise-quintic joint trajectory; build it with :mod:`rtctl.trajectory.planning`."""

    def __init__(self, knots, coeffs):
        knots = np.ascontiguousarray(knots, dtype=float)
        coeffs = np.ascontiguousarray(coeffs, dtype=float)
        if coeffs.ndim != 3 or coeffs.shape[2] != 6 or coeffs.shape[0] < 1:
            raise TrajectoryError(f"coefficients must be (segments, joints, 6), got {coeffs.shape}")
        if knots.shape != (coeffs.shape[0] + 1,) or np.any(np.diff(knots) < 0):
            raise TrajectoryError("knots must be non-decreasing, one more than the segments")
        if not (np.all(np.isfinite(knots)) and np.all(np.isfinite(coeffs))):
            raise TrajectoryError("trajectory has non-finite knots or coefficients")
        knots.setflags(write=False)
        coeffs.setflags(write=False)
        self.knots = knots
        self.coeffs = coeffs

    @classmethod
    def from_segments(cls, t0: float, durations, coeffs) -> "JointTrajectory":
        """Segments of the given durations laid end to end from time ``t0``."""
        knots = t0 + np.concatenate(([0.0], np.cumsum(durations)))
        return cls(knots, coeffs)

    @property
    def n(self) -> int:
        return self.coeffs.shape[1]

    @property
    def t_start(self) -> float:
        return float(self.knots[0])

    @property
    def t_end(self) -> float:
        return float(self.knots[-1])

    @property
    def duration(self) -> float:
        return self.t_end - self.t_start

    def sample(self, t: float, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> None:
        """Write the reference at time ``t`` into the preallocated float64 arrays (allocates nothing)."""
        _sample(self.knots, self.coeffs, t, q, qd, qdd)

    def state_at(self, t: float):
        """(q, q̇, q̈) at ``t`` as new arrays — for planning and tests, not the tick."""
        out = np.empty((3, self.n))
        _sample(self.knots, self.coeffs, float(t), out[0], out[1], out[2])
        return out[0], out[1], out[2]
