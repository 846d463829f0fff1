"""The Sage–Husa filter (19)-(27) of docs/arma_kalman.md with none of the safeguards of
:mod:`rtctl.estimation.sage_husa`: R̂ from (25) as written (it may go negative, and the gain's
denominator hᵀPh + R̂ with it), Q̂ from (27) as the full p × p matrix, P from (23) as written.
One channel, plain numpy, allocating: a reference for the study (scripts/arma_gmv_study.py,
the sweep's "printed equations" row) and for the tests that show why the shipped filter departs
from it — not for a control loop.
"""
from __future__ import annotations

import numpy as np

from rtctl.estimation.sage_husa import SWITCH_NAMES


class PrintedSageHusa:
    """One channel of p coefficients; ``adapt`` ⊂ {"r", "R", "q", "Q"} as in
    :class:`~rtctl.estimation.sage_husa.SageHusa`; ``P0``, ``Q0``: diagonals (p,)."""

    def __init__(self, p: int, *, lam: float, theta0, P0, r0: float, R0: float, Q0, adapt=("r", "R", "Q")):
        if not 0.0 < lam < 1.0:
            raise ValueError(f"lam must be in (0, 1), got {lam!r}")
        unknown = set(adapt) - set(SWITCH_NAMES)
        if unknown:
            raise ValueError(f"adapt: unknown switches {sorted(unknown)}; known: {', '.join(SWITCH_NAMES)}")
        shapes = [np.shape(v) for v in (theta0, P0, Q0)]
        if any(s != (p,) for s in shapes):
            raise ValueError(f"theta0, P0 and Q0 must have {p} entries, got shapes {shapes}")
        self.lam, self.adapt = float(lam), frozenset(adapt)
        self.theta = np.array(theta0, dtype=float)
        self.P, self.Q = np.diag(np.asarray(P0, float)), np.diag(np.asarray(Q0, float))
        self.q = np.zeros(p)
        self.r, self.R = float(r0), float(R0)
        self.k = 0

    def update(self, h, y: float) -> float:
        """One step with regressor ``h`` (p,) and measurement ``y``; returns the innovation ε (20)."""
        h = np.asarray(h, dtype=float)
        if h.shape != self.theta.shape:
            raise ValueError(f"h must have {self.theta.size} entries, got shape {h.shape}")
        d = (1.0 - self.lam) / (1.0 - self.lam ** (self.k + 1))
        self.k += 1
        theta_prev, P_prev = self.theta.copy(), self.P.copy()  # θ̂(k|k), P(k|k)
        theta_pred = self.theta + self.q  # (19)
        P_pred = self.P + self.Q  # (22)
        pred = y - h @ theta_pred
        eps = pred - self.r  # (20)
        s = h @ P_pred @ h
        K = P_pred @ h / (s + self.R)  # (21)
        self.theta = theta_pred + K * eps  # (18)
        self.P = (np.eye(h.size) - np.outer(K, h)) @ P_pred  # (23)
        if "r" in self.adapt:
            self.r = (1 - d) * self.r + d * pred  # (24)
        if "R" in self.adapt:
            self.R = (1 - d) * self.R + d * (eps * eps - s)  # (25)
        if "q" in self.adapt:
            self.q = (1 - d) * self.q + d * (self.theta - theta_prev)  # (26)
        if "Q" in self.adapt:
            self.Q = (1 - d) * self.Q + d * (np.outer(K, K) * eps * eps + self.P - P_prev)  # (27)
        return float(eps)
