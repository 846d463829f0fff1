"""Numerical inverse kinematics for any chain: damped Levenberg-Marquardt on the pose error.

The error of joint angles q for a target pose (p*, R*) is e = [p* − p(q); log(R* R(q)ᵀ)]
(position and rotation vector, base coordinates), and the geometric Jacobian J(q) maps a
joint step to its first-order change. Each step solves (JᵀJ + λ1) Δq = Jᵀe; λ shrinks after a
step that lowers ‖e‖ and grows after one that does not (Levenberg 1944, Marquardt 1963), so
the solver behaves like gradient descent far from the goal and like Gauss-Newton near it, and
stays defined at singular and redundant (n > 6) configurations. Joint limits are kept by
projecting every iterate onto them. A run that stalls is restarted from random joint angles
drawn within the limits (seeded, so results are reproducible).
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.errors import KinematicsError
from rtctl.model.kinematics import fk, jacobian
from rtctl.model.robot import PRISMATIC, Model


def rotation_vector(R) -> np.ndarray:
    """log(R) as a rotation vector θk, accurate near θ = 0 and θ = π."""
    vee = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = 0.5 * np.linalg.norm(vee)  # sin θ
    c = 0.5 * (np.trace(R) - 1.0)  # cos θ
    theta = math.atan2(s, c)
    if s > 1e-6 or c > 0.0:
        # θ / sin θ → 1 as θ → 0: the first-order form is exact to O(θ³) there.
        return vee * (0.5 * theta / s if s > 1e-12 else 0.5)
    # θ near π: k kᵀ = (R + I) / 2 to O(π − θ); take its best-conditioned column, signed by vee.
    B = 0.5 * (R + np.eye(3))
    j = int(np.argmax(np.diag(B)))
    k = B[:, j] / math.sqrt(B[j, j])
    if k @ vee < 0.0:
        k = -k
    return theta * k / np.linalg.norm(k)


def pose_error(pose, target) -> np.ndarray:
    """[p* − p; log(R* Rᵀ)]: what the tool must still move, in base coordinates."""
    return np.concatenate([target[:3, 3] - pose[:3, 3], rotation_vector(target[:3, :3] @ pose[:3, :3].T)])


def _sample_limits(model: Model):
    lo = np.where(np.isfinite(model.q_min), model.q_min, -np.pi)
    hi = np.where(np.isfinite(model.q_max), model.q_max, np.pi)
    return lo, hi


def _descend(model: Model, target, q, tol: float, max_iter: int, project: bool):
    """One Levenberg-Marquardt run from q → (q, ‖e‖), iterates kept in the limits if ``project``."""
    e = pose_error(fk(model, q), target)
    err = float(np.linalg.norm(e))
    lam = 1e-3
    for _ in range(max_iter):
        if err < tol:
            break
        J = jacobian(model, q)
        H = J.T @ J
        H[np.diag_indices_from(H)] += lam
        q_new = q + np.linalg.solve(H, J.T @ e)
        if project:
            q_new = np.clip(q_new, model.q_min, model.q_max)
        e_new = pose_error(fk(model, q_new), target)
        err_new = float(np.linalg.norm(e_new))
        if err_new < err:
            q, e, err = q_new, e_new, err_new
            lam = max(lam * 0.1, 1e-12)
        else:
            lam *= 10.0
            if lam > 1e6:  # no descent direction left: a local minimum or a limit
                break
    return q, err


def _into_limits(model: Model, q, ref):
    """q with revolute angles moved by whole turns into the limits, nearest ``ref``; or None."""
    revolute = model.joint_types != PRISMATIC
    q = np.where(revolute, np.remainder(q - ref + np.pi, 2.0 * np.pi) - np.pi + ref, q)
    cand = q[None, :] + 2.0 * np.pi * np.arange(-2, 3)[:, None] * revolute
    ok = (cand >= model.q_min - 1e-12) & (cand <= model.q_max + 1e-12)  # rounding of the wrap
    if not np.all(ok.any(axis=0)):
        return None
    best = cand[np.argmin(np.where(ok, np.abs(cand - ref), np.inf), axis=0), np.arange(model.nq)]
    return np.clip(best, model.q_min, model.q_max)


def _attempt(model: Model, target, start, ref, tol: float, max_iter: int):
    """From one start: the free descent (fast, rarely trapped), its result turned into the
    limits by whole turns; failing that, the descent projected onto the limits."""
    q, err = _descend(model, target, start, tol, max_iter, project=False)
    fitted = _into_limits(model, q, ref) if err < tol else None
    if fitted is None:
        q, err = _descend(model, target, start, tol, max_iter, project=True)
        fitted = _into_limits(model, q, ref)
    return fitted, err


def solve(model: Model, target, q_seed=None, *, tol: float = 1e-12, max_iter: int = 200,
          restarts: int = 50, seed: int = 0) -> np.ndarray:
    """Joint angles within the limits with ‖pose error‖ < ``tol`` (metres/radians), from
    ``q_seed`` (default: mid-range) and then up to ``restarts`` random starts; revolute
    angles are reported, among their whole-turn equivalents within the limits, nearest the seed."""
    target = np.asarray(target, dtype=float)
    lo, hi = _sample_limits(model)
    rng = np.random.default_rng(seed)
    start = (0.5 * (lo + hi)) if q_seed is None else np.clip(np.asarray(q_seed, dtype=float), model.q_min, model.q_max)
    ref = start.copy()  # whole turns are chosen to land nearest the seed
    best_err = np.inf
    for _ in range(restarts + 1):
        q, err = _attempt(model, target, start, ref, tol, max_iter)
        best_err = min(best_err, err)
        if q is not None and err < tol:
            return q
        start = rng.uniform(lo, hi)
    raise KinematicsError(f"{model.name}: numerical IK did not converge (pose error {best_err:.3g} "
                          f"after {restarts + 1} starts); the pose may be out of reach or the limits too tight")
