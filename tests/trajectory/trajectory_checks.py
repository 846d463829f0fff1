"""Shared checks: dense sampling, limits, continuity by finite differences."""
import numpy as np


def dense(traj, dt=2e-4, pad=0.05, before=True):
    """Sample a trajectory densely (with ``pad`` s after, and before if ``before``): t, q, qd, qdd."""
    ts = np.arange(traj.t_start - pad * before, traj.t_end + pad, dt)
    out = np.empty((3, len(ts), traj.n))
    for i, t in enumerate(ts):
        traj.sample(t, out[0, i], out[1, i], out[2, i])
    return ts, out[0], out[1], out[2]


def assert_within(traj, limits, rtol=1e-7):
    _, q, qd, qdd = dense(traj)
    assert np.all(np.abs(qd) <= limits.v_max * (1 + rtol)), np.max(np.abs(qd) / limits.v_max)
    assert np.all(np.abs(qdd) <= limits.a_max * (1 + rtol)), np.max(np.abs(qdd) / limits.a_max)
    if limits.q_min is not None:
        assert np.all(q >= limits.q_min) and np.all(q <= limits.q_max)


def jerk_bound(traj):
    """An upper bound of |d³q/dt³| from the coefficients (not from samples, which may jump)."""
    c, T = traj.coeffs, np.diff(traj.knots)[:, None]
    return float(np.max(6 * np.abs(c[..., 3]) + 24 * np.abs(c[..., 4]) * T + 60 * np.abs(c[..., 5]) * T**2))


def assert_continuous(traj, dt=2e-4):
    """q̇ and q̈ agree with central differences of q and q̇ everywhere, knots included. A jump
    of δ in q, q̇ or q̈ would show as an error of about δ/(2 dt), δ/2 or δ/2, against bounds of
    jerk·dt²/6 and jerk·dt (Taylor remainders) plus rounding. From the start on: before it the
    start state is held as it is (with its velocity, when a retarget starts moving)."""
    ts, q, qd, qdd = dense(traj, dt, before=False)
    fd_v = (q[2:] - q[:-2]) / (2 * dt)
    fd_a = (qd[2:] - qd[:-2]) / (2 * dt)
    j = jerk_bound(traj)
    assert np.max(np.abs(fd_v - qd[1:-1])) <= j * dt**2 / 6 + 1e-9
    assert np.max(np.abs(fd_a - qdd[1:-1])) <= j * dt + 1e-9
