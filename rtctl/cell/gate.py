"""Waiting at a shared zone's border: the running trajectory, time-scaled (docs/cell.md).

A path that enters a shared zone W whose lease the robot does not hold must wait at W's
border, not fail. The :class:`Gate` wraps the running :class:`~rtctl.trajectory.JointTrajectory`
and follows it at a rate s ∈ [0, 1] of loop time: the reference is q(τ), q̇(τ)·s,
q̈(τ)·s² + q̇(τ)·ṡ with dτ/dt = s. Every tick (:func:`gate_step`, one compiled call):

* the reference's path ahead, τ … τ + L, is sampled every Δτ (on a fixed grid: each sample is
  measured once, when it comes into sight) and each sample's depth in every shared zone is
  kept; a zone's *entry* is the offset of the first sample within the gate margin m_g of it
  (∞: none within L);
* braking at the rate change b the path admits (|q̇ⱼ|·b ≤ aⱼ/2 for every speed joint j reaches
  between two samples) lowers s² by 2·b per unit of τ, so the braking room up to the last
  sample before a zone is Σ 2·b·Δτ; the rate rises towards 1 while s² fits in the room before
  every zone whose lease is missing, is held at √room when it no longer would, and falls at
  the admissible rate when it must — so the reference comes to rest before the first zone it
  may not enter, and moves on once the lease arrives;
* samples Δτ apart with the reference's speed at most ‖v_max‖ (over the joints the zones
  involve) certify the path between them to within ‖v_max‖·Δτ/2 = m_g/2 (depth is
  1-Lipschitz): a reference at rest at a border keeps at least m_g/2 from the zone.

A zone counts as held while ``t < expiry`` (the loop time the lease ends, less the horizon the
robot needs to stop: :mod:`rtctl.cell.shared`). The added acceleration q̇·ṡ stays within a/2;
the rate changes from 0 to 1 in no fewer than ``RAMP_TICKS`` ticks.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.compiled import kernel
from rtctl.guard.kernels import piece_depth
from rtctl.trajectory.piecewise import _sample

# the gate's state (float array): τ, the rate, the last tick's time, whether it ran, the grid's
# origin τ₀ and the next grid sample to measure
TAU, RATE, T_LAST, STARTED, TAU0, NEXT_K = range(6)
N_STATE = 6
# its parameters
RAMP, STEP, LOOKAHEAD, MARGIN = range(4)
N_PARAMS = 4
MAX_SAMPLES = 256  # per tick: the look-ahead's cost is bounded whatever the speeds
RAMP_TICKS = 10  # the rate changes from 0 to 1 in no fewer ticks, however slow the path
LEAD_S = 0.5  # of trajectory time: a zone this far ahead is wanted (its lease is asked for) already


@kernel(error_model="numpy")
def _brake_rate(qd, prev, accel, step, cap):  # pragma: no cover - compiled
    """The rate change b (1/s) the path admits between two samples whose velocities are ``prev``
    and ``qd``: |q̇ⱼ|·b ≤ aⱼ/2 for every speed q̇ⱼ can reach between them (|q̈ⱼ| ≤ aⱼ)."""
    b = cap
    for j in range(qd.shape[0]):
        v = max(abs(qd[j]), abs(prev[j])) + accel[j] * step
        if v > 0.0 and 0.5 * accel[j] / v < b:
            b = 0.5 * accel[j] / v
    return b


@kernel(error_model="numpy")
def _measure(knots, coeffs, tau, rows, cols, pieces, out, nz, tmp):  # pragma: no cover - compiled
    """Sample the path at τ into tmp[0..2]; out[z] = its smallest depth in zone z's pieces."""
    _sample(knots, coeffs, tau, tmp[0], tmp[1], tmp[2])
    for z in range(nz):
        out[z] = np.inf
    for p in range(pieces.shape[0]):
        d = piece_depth(rows, cols, pieces[p, 0], pieces[p, 1], tmp[0])
        if d < out[pieces[p, 2]]:
            out[pieces[p, 2]] = d


@kernel(error_model="numpy")
def gate_step(knots, coeffs, t, expiry, rows, cols, pieces, accel, par, st, ring, entry, room, held, waiting,
              q, qd, qdd, tmp):  # pragma: no cover - compiled
    """One tick of the gate: update the rate and τ in ``st``, write the reference into q, qd,
    qdd; per zone, ``entry`` (offset of the first sample within the margin, inf: none),
    ``room`` (the braking capacity up to the last sample before it), ``held`` (1/0) and
    ``waiting`` (1 when that zone is what holds the reference back).

    The samples lie on a grid τ₀ + k·Δτ and are kept in ``ring`` (a row per sample, at k modulo
    its rows but the last: each zone's depth, then b over the step that ends there): a tick
    measures only the samples that came into sight since the last one — usually none or one —
    and the point it is at."""
    nz, n_ring = entry.shape[0], ring.shape[0] - 1  # (its last row: the point the reference is at)
    here = ring[n_ring]
    dt = t - st[T_LAST] if st[STARTED] != 0.0 else 0.0
    st[T_LAST], st[STARTED] = t, 1.0
    step, margin, cap = par[STEP], par[MARGIN], 1.0 / par[RAMP]
    dt = min(max(dt, 0.0), step)  # (skipped periods: the path slows rather than jumps past a border)
    tau = st[TAU]
    for z in range(nz):
        entry[z] = np.inf
        room[z] = np.inf
        held[z] = 1.0 if t < expiry[z] else 0.0
        waiting[z] = 0.0
    # the point the reference is at (its zones, and the braking rate until the next grid point)
    _measure(knots, coeffs, tau, rows, cols, pieces, here, nz, tmp)
    for z in range(nz):
        if here[z] < margin:
            entry[z], room[z] = 0.0, -1.0
    b_first = _brake_rate(tmp[1], tmp[1], accel, step, cap)  # (a speed within Δτ of here: |q̇| + a·Δτ)
    # the grid samples in sight: k_now + 1 … k_now + n_ahead, measured once each
    n_ahead = int(par[LOOKAHEAD] / step) + 2
    k_now = int(math.floor((tau - st[TAU0]) / step))
    k_last = k_now + n_ahead
    k = int(st[NEXT_K]) if st[NEXT_K] > k_now else k_now
    first = k
    while k <= k_last:
        slot = k % n_ring
        _measure(knots, coeffs, st[TAU0] + k * step, rows, cols, pieces, ring[slot], nz, tmp)
        ring[slot, nz] = _brake_rate(tmp[1], tmp[3], accel, step, cap) if k > first or first > k_now else 0.0
        for j in range(tmp.shape[1]):
            tmp[3, j] = tmp[1, j]  # (the last sample's velocity, for the next one's b)
        k += 1
    st[NEXT_K] = k
    # braking room: Σ 2·b·Δτ over the steps from grid point k_now + 2 on (a tick moves τ by at
    # most one Δτ, so it never passes that point) up to the last sample clear of each zone
    capacity, before = 0.0, -1.0
    for i in range(1, n_ahead + 1):
        slot = (k_now + i) % n_ring
        if i >= 3:
            capacity += 2.0 * ring[slot, nz] * step
        for z in range(nz):
            if entry[z] == np.inf and ring[slot, z] < margin:
                entry[z] = st[TAU0] + (k_now + i) * step - tau
                room[z] = before
        before = capacity if i >= 2 else -1.0
    s = st[RATE]
    s_try = min(1.0, s + b_first * dt)
    s_new = s_try
    for z in range(nz):
        if held[z] == 0.0 and s_try * s_try > room[z]:
            waiting[z] = 1.0  # the highest rate that can still stop in the room (no bang-bang at its edge)
            s_new = min(s_new, math.sqrt(room[z]) if room[z] > 0.0 else 0.0)
    s_new = max(s_new, s - b_first * dt, 0.0)
    s_dot = (s_new - s) / dt if dt > 0.0 else 0.0
    st[TAU] += 0.5 * (s + s_new) * dt
    st[RATE] = s_new
    _sample(knots, coeffs, st[TAU], q, qd, qdd)
    for j in range(q.shape[0]):
        qdd[j] = qdd[j] * s_new * s_new + qd[j] * s_dot
        qd[j] *= s_new


class Gate:
    """``trajectory`` (a JointTrajectory) followed from loop time ``t0`` at the gate's rate;
    ``zones`` the loop's :class:`~rtctl.cell.shared.SharedZones` (tables, expiries, outputs)."""

    def __init__(self, trajectory, zones, t0: float):
        self.inner, self.zones = trajectory, zones
        self.st = np.zeros(N_STATE)
        self.st[TAU], self.st[RATE], self.st[T_LAST], self.st[TAU0], self.st[NEXT_K] = t0, 1.0, t0, t0, -1.0

    def sample(self, t: float, q, qd, qdd) -> None:
        z = self.zones
        gate_step(self.inner.knots, self.inner.coeffs, t, z.gate_expiry, z.rows, z.cols, z.pieces, z.accel,
                  z.gate_par, self.st, z.ring, z.entry, z.room, z.held, z.waiting, q, qd, qdd, z.tmp)

    # -- what the daemon and its moves ask of a trajectory (in loop time) ----------------
    @property
    def n(self) -> int:
        return self.inner.n

    @property
    def tau(self) -> float:
        return float(self.st[TAU])

    @property
    def rate(self) -> float:
        return float(self.st[RATE])

    @property
    def finished(self) -> bool:
        return self.st[TAU] >= self.inner.t_end

    @property
    def t_start(self) -> float:
        return self.inner.t_start

    @property
    def t_end(self) -> float:
        """When the path would end from now at full rate (a waiting path has not ended); once
        it has ended, a time at or before then."""
        if self.finished:
            return min(float(self.st[T_LAST]), self.inner.t_end)
        return float(self.st[T_LAST] + self.inner.t_end - self.st[TAU])

    def state_at(self, t: float):
        """The reference at loop time ``t``, assuming full rate from now on; while the gate
        slows or waits, where the reference is now (a move asked then starts from there)."""
        if self.st[RATE] < 1.0:
            q, qd, qdd = self.inner.state_at(self.st[TAU])
            return q, qd * self.st[RATE], np.zeros_like(qdd)
        return self.inner.state_at(self.st[TAU] + max(0.0, t - self.st[T_LAST]))


def ring_rows(par) -> int:
    """The rows of the gate's sample ring: every sample in sight, two spare, the point it is at."""
    return int(par[LOOKAHEAD] / par[STEP]) + 2 + 3


def gate_parameters(v_max, a_max, margin: float, dt: float, joints=None) -> np.ndarray:
    """(shortest ramp, sample step Δτ, look-ahead L, margin m_g) from the run's limits and
    period (see above); ``joints``: those the zones involve (depth depends on no other)."""
    v_max, a_max = np.asarray(v_max, float), np.asarray(a_max, float)
    if v_max.ndim != 1 or v_max.shape != a_max.shape or not np.all((v_max > 0) & (a_max > 0)):
        raise ValueError("v_max and a_max: positive, one per joint")
    if not (math.isfinite(margin) and margin > 0):
        raise ValueError(f"margin: expected > 0, got {margin!r}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt: expected > 0, got {dt!r}")
    lookahead = LEAD_S + 1.25 * float(np.max(v_max / a_max)) + 0.1  # (braking from full rate covers ≤ v/a)
    speed = float(np.linalg.norm(v_max if joints is None else v_max[list(joints)]))
    step = max(margin / speed, lookahead / (MAX_SAMPLES - 2), dt)  # (≥ dt: a tick moves at most one step)
    par = np.zeros(N_PARAMS)
    par[RAMP], par[STEP], par[LOOKAHEAD], par[MARGIN] = RAMP_TICKS * dt, step, lookahead, margin
    return par
