"""Stability margins of Slotine–Li adaptive control sampled at period T behind a wire that
delays the measurement by d periods (docs/cstar_delay.md).

Along a trajectory, with the regressor Y and the inertia H frozen at a point, the closed loop
of τ = Y π̂ − K_D s, dπ̂/dt = −P Yᵀ s is (s = q̇ − q̇_r, π̃ = π̂ − π, w = Y π̃ the torque error
of the estimates)

    H ṡ = −K_D s + w,      ẇ = −Y P Yᵀ s = −M s          (C s, second order, left out)

— a mass–spring–damper per mode of M: the adaptation is a spring of stiffness M on s, damped by
K_D. In continuous time it is stable for any P ≥ 0. Sampled at T (Euler, as the controller
integrates) with the measurement d periods old, both feedback paths act on s_{k−d}:

    s_{k+1} = s_k + T H⁻¹ (−K_D s_{k−d} + w_k),      w_{k+1} = w_k − T M s_{k−d}

and the loop is stable iff the spectral radius ρ of that map is < 1. The margin of a gain is
the factor by which it can grow (or, for K_D, also shrink) before ρ reaches 1, at the worst
point of the trajectory. w = 0 gives the PD part alone.

Only w is kept, and of w only its part in the range of M: π̃ outside the range of Yᵀ does not
move (those parameters are not excited at that point) and would only add eigenvalues at 1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rtctl.model.dynamics import mass_matrix
from rtctl.model.regressor import slotine_li_regressor


def closed_loop(Hinv: np.ndarray, KD: np.ndarray, M: np.ndarray | None, T: float, d: int) -> np.ndarray:
    """The one-period map of z = (s_k, s_{k−1}, …, s_{k−d}, c_k) with w = U c over the range
    of M (its unexcited directions only add eigenvalues at 1); M = None: PD only."""
    n = len(KD)
    U = np.zeros((n, 0))
    if M is not None:
        lam, V = np.linalg.eigh(M)
        keep = lam > 1e-9 * max(lam.max(), 1e-300)
        U, lam = V[:, keep], lam[keep]
    r = U.shape[1]
    size = (d + 1) * n + r
    A = np.zeros((size, size))
    A[:n, :n] = np.eye(n)
    A[:n, d * n:(d + 1) * n] -= T * Hinv @ np.diag(KD)
    for j in range(1, d + 1):  # the delay line
        A[j * n:(j + 1) * n, (j - 1) * n:j * n] = np.eye(n)
    if r:
        c = slice((d + 1) * n, size)
        A[:n, c] = T * Hinv @ U
        A[c, c] = np.eye(r)
        A[c, d * n:(d + 1) * n] = -T * lam[:, None] * U.T
    return A


def spectral_radius(A: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(A))))


def _stable(Hinv, KD, M, T, d) -> bool:
    return spectral_radius(closed_loop(Hinv, KD, M, T, d)) < 1.0


def _edge(stable_at, lo: float, hi: float, steps: int = 20) -> float:
    """Where stability is lost between ``lo`` (stable) and ``hi`` (unstable): bisection in log."""
    for _ in range(steps):
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if stable_at(mid) else (lo, mid)
    return lo


_GRID = np.logspace(-3, 3, 13)  # where a stable factor is looked for when 1 is not


def _reach(stable_at, start: float, step: float, steps: int = 12) -> float:
    """From a stable ``start``, the last stable factor going by ``step`` (×2 or ÷2) then
    bisecting; 0 or inf when still stable after ``steps`` steps."""
    f = start
    for _ in range(steps):
        if not stable_at(f * step):
            return _edge(stable_at, f, f * step, steps=20)
        f *= step
    return float("inf") if step > 1 else 0.0


def stable_interval(stable_at) -> tuple[float, float]:
    """The interval of gain factors f with ``stable_at(f)`` that contains 1, or (when 1 is
    unstable) the one nearest to 1 on a coarse grid; (nan, nan) if none is found."""
    start = 1.0
    if not stable_at(start):
        stable = [f for f in sorted(_GRID, key=lambda f: abs(np.log(f))) if stable_at(f)]
        if not stable:
            return float("nan"), float("nan")
        start = stable[0]
    return _reach(stable_at, start, 0.5), _reach(stable_at, start, 2.0)


@dataclass
class PointMargins:
    rho: float  # spectral radius at the configured gains
    p_max: float  # the largest factor on P that keeps the loop stable (< 1: P must shrink)
    kd_min: float  # K_D's factor range that keeps it stable (below: the adaptation is left
    kd_max: float  # underdamped; above: the PD part outruns the delay)
    rho_pd: float  # PD part alone (no adaptation)


def point_margins(H, KD, M, T: float, d: int) -> PointMargins:
    """Margins at one point: inertia H, damping KD (per joint), adaptation stiffness M."""
    Hinv = np.linalg.inv(H)
    p_lo, p_hi = stable_interval(lambda f: _stable(Hinv, KD, f * M, T, d))
    kd_lo, kd_hi = stable_interval(lambda f: _stable(Hinv, f * KD, M, T, d))
    return PointMargins(rho=spectral_radius(closed_loop(Hinv, KD, M, T, d)), p_max=p_hi, kd_min=kd_lo,
                        kd_max=kd_hi, rho_pd=spectral_radius(closed_loop(Hinv, KD, None, T, d)))


def loop_points(model, controller, trajectory, *, samples: int = 60, motor_model: bool = True):
    """(H, M = Y P Yᵀ, K_D + B) at ``samples`` times along ``trajectory`` (perfect tracking:
    q = q_d, q̇_r = q̇_d, q̈_r = q̈_d) for a :class:`~rtctl.control.slotine_li.SlotineLi`. With
    the robot file's drive train (``motor_model``), H includes the rotors' armature and the
    damping the viscous friction: what is left of them around the feed-forward."""
    n = model.nq
    P = controller.gamma.reshape(-1)
    motors = model.motors if motor_model else None
    armature = np.zeros(n) if motors is None else motors.armature
    damping = np.asarray(controller.kd, float) + (0.0 if motors is None else motors.viscous)
    q, qd, qdd = np.zeros(n), np.zeros(n), np.zeros(n)
    for t in np.linspace(trajectory.knots[0], trajectory.t_end, samples):
        trajectory.sample(t, q, qd, qdd)
        Y = slotine_li_regressor(model, q, qd, qd, qdd)  # (q̇_r = q̇: C q̇ is one vector, whichever law's C)
        yield mass_matrix(model, q) + np.diag(armature), (Y * P) @ Y.T, damping


def trajectory_margins(model, controller, trajectory, rate_hz: float, delays=(0, 1, 2), *, samples: int = 24,
                       motor_model: bool = True) -> dict[int, PointMargins]:
    """Per delay d (periods), the worst margins over the trajectory; with the robot file's drive
    train by default, as :func:`loop_points`."""
    points = list(loop_points(model, controller, trajectory, samples=samples, motor_model=motor_model))
    T = 1.0 / rate_hz
    out = {}
    for d in delays:
        ms = [point_margins(H, D, M, T, d) for H, M, D in points]
        out[d] = PointMargins(rho=max(m.rho for m in ms), p_max=min(m.p_max for m in ms),
                              kd_min=max(m.kd_min for m in ms), kd_max=min(m.kd_max for m in ms),
                              rho_pd=max(m.rho_pd for m in ms))
    return out


def format_margins(name: str, rate_hz: float, margins: dict[int, PointMargins]) -> str:
    rows = [f"{name} at {rate_hz:g} Hz — worst point of the trajectory (stable: ρ < 1; margins are gain factors)",
            f"  {'delay':>7} {'ρ':>9} {'ρ (PD)':>9} {'P up to ×':>10} {'K_D from ×':>11} {'to ×':>7}"]
    for d, m in margins.items():
        rows.append(f"  {d:>5} T {m.rho:>9.5f} {m.rho_pd:>9.5f} {m.p_max:>10.3g} {m.kd_min:>11.3g} {m.kd_max:>7.3g}"
                    + ("   UNSTABLE" if not m.rho < 1.0 else ""))
    return "\n".join(rows)
