"""Feasibility of a target, a segment, a polyline and a trajectory (the paper's S_f ∈ Ω_I test
and "the path meets Ω_I"), with the reason: which zone, and where the path first enters it.

``margin`` defaults to the scene's: a target or path inside the margin-inflated zone is
infeasible for planning; ``margin=0`` asks about the zones themselves.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rtctl.guard import kernels as k
from rtctl.guard.zones import Scene


@dataclass(frozen=True, eq=False)
class Violation:
    """Why a point or path is infeasible. ``what``: a zone's name or "<joint> limit"; ``q``: the
    offending point — for a path, where it first enters the zone (or, when it only grazes it,
    its margin) or leaves the range; ``at``: None for a point, else the fraction along a
    segment or the time on a trajectory; ``inside``: False when only the margin is entered."""

    what: str
    q: np.ndarray
    at: float | None = None
    inside: bool = True

    def __str__(self) -> str:
        return self.describe()

    def describe(self, deg=None) -> str:
        """The reason in words; ``deg`` (a per-joint bool mask, the revolute joints) shows those
        joints in degrees, as a command asked in degrees answers."""
        q = f"q = {format_q(self.q, deg)}" + ("" if deg is None else " deg")
        if self.what.endswith(" limit"):
            return f"{'past' if self.at is None else 'goes past'} the {self.what} at {q}"
        if self.at is None:
            return f"{'inside' if self.inside else 'within the margin of'} zone {self.what!r} at {q}"
        return f"{'enters' if self.inside else 'comes within the margin of'} zone {self.what!r} at {q}"


def format_q(q, deg=None) -> str:
    """``[…]`` of joint positions in rad (m for prismatic joints), the joints of the mask ``deg``
    in degrees."""
    q = np.asarray(q, dtype=float)
    shown = q if deg is None else np.where(deg, np.degrees(q), q)
    return "[" + ", ".join(f"{x:.4g}" for x in shown) + "]"


def _vector(scene: Scene, q, name: str) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape != (scene.n,) or not np.all(np.isfinite(q)):
        raise ValueError(f"{name} must be {scene.n} finite joint values, got shape {q.shape}")
    return q


def _margin(scene: Scene, margin) -> float:
    m = scene.margin if margin is None else float(margin)
    if not np.isfinite(m) or m < 0:
        raise ValueError(f"margin must be finite and >= 0, got {margin!r}")
    return m


def point_violation(scene: Scene, q, margin=None) -> Violation | None:
    """Why ``q`` is not a feasible configuration (past a limit, inside a zone or its margin)."""
    q, m = _vector(scene, q, "q"), _margin(scene, margin)
    past = np.flatnonzero((q < scene.q_min) | (q > scene.q_max))
    if past.size:
        return Violation(f"{scene.joint_names[past[0]]} limit", q.copy())
    depth, piece = k.clearance(*scene.tables(), q)
    if depth < m:
        return Violation(scene.zone_of_piece(piece).name, q.copy(), inside=depth < 0)
    return None


def segment_violation(scene: Scene, a, b, margin=None) -> Violation | None:
    """The first point where the straight joint-space segment a→b leaves the limits or enters
    a zone (inflated by the margin); None if it does neither. Exact: Cyrus–Beck clipping."""
    a, b, m = _vector(scene, a, "a"), _vector(scene, b, "b"), _margin(scene, margin)
    for q in (a, b):  # the limits are a box: the endpoints decide
        past = np.flatnonzero((q < scene.q_min) | (q > scene.q_max))
        if past.size:
            return Violation(f"{scene.joint_names[past[0]]} limit", q.copy(), 0.0 if q is a else 1.0)
    s, piece, _ = k.segment_entry(*scene.tables(), a, b, m)
    if s >= k.NO_ENTRY:
        return None
    s_in, piece_in, _ = k.segment_entry(*scene.tables(), a, b, 0.0)
    if s_in < k.NO_ENTRY:  # it enters a zone itself: report where
        return Violation(scene.zone_of_piece(piece_in).name, a + s_in * (b - a), float(s_in))
    return Violation(scene.zone_of_piece(piece).name, a + s * (b - a), float(s), inside=False)


def path_violation(scene: Scene, points, margin=None) -> tuple[int, Violation] | None:
    """(segment index, violation) of the first segment of the polyline ``points`` that is infeasible."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    for i in range(len(points) - 1):
        v = segment_violation(scene, points[i], points[i + 1], margin)
        if v is not None:
            return i, v
    return None


def trajectory_violation(scene: Scene, trajectory, clearance: float, v_max) -> Violation | None:
    """The first time the trajectory comes closer than ``clearance`` to a zone, or leaves the
    limits; None when it never does.

    Certified by sampling: the depth is 1-Lipschitz in q, and between samples Δt apart every
    joint moves at most v_max·Δt, so samples with depth ≥ clearance + ½|v_max|Δt prove the
    whole trajectory keeps ``clearance``. Δt is chosen so that this bound costs a quarter of
    ``clearance`` (or 1 µrad when clearance is 0).
    """
    v_max = np.asarray(v_max, float)
    if v_max.shape != (scene.n,) or not np.all((v_max > 0) & np.isfinite(v_max)):
        raise ValueError(f"v_max must be {scene.n} finite positive values")
    step = max(0.5 * clearance, 2e-6)  # bound on |Δq| between samples
    dt = step / float(np.linalg.norm(v_max))
    t = np.append(np.arange(trajectory.t_start, trajectory.t_end, dt), trajectory.t_end)
    Q = positions(trajectory, t)
    depth = np.empty(len(t))
    k.clearances(*scene.tables(), Q, depth)
    need = clearance + 0.5 * step
    past = (Q < scene.q_min) | (Q > scene.q_max)
    bad = np.flatnonzero((depth < need) | past.any(axis=1))
    if bad.size == 0:
        return None
    i = bad[0]
    if past[i].any():
        return Violation(f"{scene.joint_names[np.flatnonzero(past[i])[0]]} limit", Q[i], float(t[i]))
    _, piece = k.clearance(*scene.tables(), Q[i])
    return Violation(scene.zone_of_piece(piece).name, Q[i], float(t[i]), inside=depth[i] < 0)


def positions(trajectory, t) -> np.ndarray:
    """(len(t), n) positions of a :class:`~rtctl.trajectory.JointTrajectory` at the times ``t``
    (vectorised: for checks and plots, not for the tick)."""
    knots, coeffs = trajectory.knots, trajectory.coeffs
    t = np.clip(np.asarray(t, float), knots[0], knots[-1])
    seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(coeffs) - 1)
    tau = (t - knots[seg])[:, None]
    c = coeffs[seg]  # (m, n, 6)
    q = c[:, :, 5]
    for i in range(4, -1, -1):
        q = q * tau + c[:, :, i]
    return q
