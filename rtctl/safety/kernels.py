"""The safety stage's per-tick arithmetic, compiled: state checks, command bounds, fallback.

All three work in place on preallocated arrays and allocate nothing. They live in one module
on purpose: numba's on-disk cache does not notice edits to *other* modules a compiled
function depends on, so the row and bit constants they bake in are defined here.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel

# rows of the limits table (n columns), see rtctl.safety.limits
HARD_LO, HARD_HI, SOFT_LO, SOFT_HI, V_LIM, TAU_MAX, KP_MAX, KD_MAX, FOLLOW = range(9)
N_LIMIT_ROWS = 9
# rows of the fallback table
HOLD_KP, HOLD_KD, DAMP_KD, Q_HOLD, TAU_HOLD = range(5)
N_FALLBACK_ROWS = 5
# rows of the stage's integer work table (n + 1 columns; column n: robot-wide latched faults)
STALE_COUNT, FLAGS, LATCHED, DEVICE, CLAMP_TORQUE, CLAMP_POSITION, CLAMP_IMPEDANCE, FOLLOW_COUNT = range(8)
N_INT_ROWS = 8
# what check_tick found
OK, NEW_STATE_FAULT, NONFINITE_COMMAND_FOUND = 0, 1, 2
# fault bits, per joint (rtctl.safety.faults.FaultKind mirrors them)
POSITION, VELOCITY, NONFINITE_STATE, STALE, DEVICE_ERROR, DEVICE_DEACTIVATE = 1, 2, 4, 8, 16, 32
NONFINITE_COMMAND, CONTROLLER, GUARD, ESTOP, FOLLOWING = 64, 128, 256, 512, 1024
# command modes (rtctl.hal.joints.CommandMode) and fallback kinds
TORQUE, IMPEDANCE = 0, 1
FB_HOLD, FB_DAMP, FB_OFF = 0, 1, 2


@kernel
def scan_state(q, qd, fresh, statuses, lim, iw, stale_ticks, q_ref, follow, follow_ticks):  # pragma: no cover
    """Per joint j: set ``iw[FLAGS, j]`` to the faults its state shows this tick; returns
    how many joints show one not latched yet. ``iw[STALE_COUNT, j]`` counts consecutive
    ticks without fresh data; the ``stale_ticks``-th one is a fault. A device status other
    than OK (``statuses[iw[DEVICE, j]]``) flags all of its joints: 2 (DEACTIVATE) as
    DEVICE_DEACTIVATE, anything else as DEVICE_ERROR. While ``follow`` (controllers in
    charge of a reference), ``iw[FOLLOW_COUNT, j]`` counts consecutive ticks with
    |q_ref − q| over ``lim[FOLLOW, j]``; the ``follow_ticks``-th one is a FOLLOWING fault."""
    new = 0
    for j in range(q.shape[0]):
        f = 0
        if not (np.isfinite(q[j]) and np.isfinite(qd[j])):
            f |= NONFINITE_STATE
        else:
            if q[j] < lim[HARD_LO, j] or q[j] > lim[HARD_HI, j]:
                f |= POSITION
            if abs(qd[j]) > lim[V_LIM, j]:
                f |= VELOCITY
        if follow and abs(q_ref[j] - q[j]) > lim[FOLLOW, j]:  # False for a NaN: the non-finite checks' case
            iw[FOLLOW_COUNT, j] += 1
            if iw[FOLLOW_COUNT, j] >= follow_ticks:
                f |= FOLLOWING
        else:
            iw[FOLLOW_COUNT, j] = 0
        if fresh[j]:
            iw[STALE_COUNT, j] = 0
        else:
            iw[STALE_COUNT, j] += 1
            if iw[STALE_COUNT, j] >= stale_ticks:
                f |= STALE
        s = statuses[iw[DEVICE, j]]
        if s == 2:
            f |= DEVICE_DEACTIVATE
        elif s != 0:
            f |= DEVICE_ERROR
        iw[FLAGS, j] = f
        if f & ~iw[LATCHED, j]:
            new += 1
    return new


@kernel
def check_tick(q, qd, fresh, statuses, lim, iw, stale_ticks, q_ref, follow, follow_ticks, bound, mode, q_des,
               qd_des, kp, kd, tau_ff):  # pragma: no cover
    """The stage's whole steady-state work in one call: :func:`scan_state`, then (if
    ``bound``) :func:`bound_command`. Returns OK, NEW_STATE_FAULT (command not bounded) or
    NONFINITE_COMMAND_FOUND (command untouched)."""
    if scan_state(q, qd, fresh, statuses, lim, iw, stale_ticks, q_ref, follow, follow_ticks):
        return NEW_STATE_FAULT
    if bound and bound_command(mode, q, qd, q_des, qd_des, kp, kd, tau_ff, lim, iw) >= 0:
        return NONFINITE_COMMAND_FOUND
    return OK


@kernel
def bound_command(mode, q, qd, q_des, qd_des, kp, kd, tau_ff, lim, iw):  # pragma: no cover
    """Bound the command in place; returns the first joint with a non-finite command field
    (the command is then left untouched for the fault record), else -1.

    Torque mode (τ = tau_ff): past a soft position limit a torque pushing further out is
    zeroed; then τ is clamped to ±tau_max. Impedance mode (the drive closes
    τ = kp(q_des − q) + kd(qd_des − q̇) + tau_ff): kp, kd within [0, max]; q_des inside the
    soft limits; |qd_des| ≤ v_lim; then tau_ff is shifted so that τ predicted at the current
    state does not push past a soft limit and stays within ±tau_max.
    """
    n = q.shape[0]
    for j in range(n):
        ok = np.isfinite(tau_ff[j])
        if mode == IMPEDANCE:
            ok = ok and np.isfinite(q_des[j]) and np.isfinite(qd_des[j]) and np.isfinite(kp[j]) and np.isfinite(kd[j])
        if not ok:
            return j
    for j in range(n):
        tmax = lim[TAU_MAX, j]
        if mode == IMPEDANCE:
            changed = False
            if kp[j] < 0.0 or kp[j] > lim[KP_MAX, j]:
                kp[j] = min(max(kp[j], 0.0), lim[KP_MAX, j])
                changed = True
            if kd[j] < 0.0 or kd[j] > lim[KD_MAX, j]:
                kd[j] = min(max(kd[j], 0.0), lim[KD_MAX, j])
                changed = True
            if q_des[j] < lim[SOFT_LO, j] or q_des[j] > lim[SOFT_HI, j]:
                q_des[j] = min(max(q_des[j], lim[SOFT_LO, j]), lim[SOFT_HI, j])
                changed = True
            if abs(qd_des[j]) > lim[V_LIM, j]:
                qd_des[j] = min(max(qd_des[j], -lim[V_LIM, j]), lim[V_LIM, j])
                changed = True
            if changed:
                iw[CLAMP_IMPEDANCE, j] += 1
            spring = kp[j] * (q_des[j] - q[j]) + kd[j] * (qd_des[j] - qd[j])
        else:
            spring = 0.0
        tau = spring + tau_ff[j]
        if (q[j] > lim[SOFT_HI, j] and tau > 0.0) or (q[j] < lim[SOFT_LO, j] and tau < 0.0):
            tau = 0.0
            iw[CLAMP_POSITION, j] += 1
        if tau > tmax:
            tau = tmax
            iw[CLAMP_TORQUE, j] += 1
        elif tau < -tmax:
            tau = -tmax
            iw[CLAMP_TORQUE, j] += 1
        tau_ff[j] = tau - spring
    return -1


@kernel
def fallback(mode, kind, q, qd, q_des, qd_des, kp, kd, tau_ff, lim, fb):  # pragma: no cover
    """Write the fallback command for every joint.

    FB_HOLD: PD to the position held at the fault with damping, plus the gravity torque there
    when known: τ = K_h(q_hold − q) − D q̇ + τ_hold (in impedance mode the drive closes it);
    FB_DAMP: τ = −D q̇ + τ_hold (damping that carries the arm's weight as it was at the fault,
    so a controlled stop decelerates instead of sagging; τ_hold = 0 when gravity is unknown);
    FB_OFF: zero. A joint whose state is not finite gets damping if its
    velocity is finite, else zero torque. Torques are clamped to ±tau_max. Returns the
    largest |q̇| (inf if one is not finite), to tell when a stop is complete.
    """
    speed = 0.0
    for j in range(q.shape[0]):
        tmax = lim[TAU_MAX, j]
        q_ok = np.isfinite(q[j]) and np.isfinite(fb[Q_HOLD, j])
        v_ok = np.isfinite(qd[j])
        speed = max(speed, abs(qd[j])) if v_ok else np.inf
        k = kind
        if k == FB_HOLD and not (q_ok and v_ok):
            k = FB_DAMP
        if k == FB_DAMP and not v_ok and mode == TORQUE:
            k = FB_OFF
        if mode == IMPEDANCE:
            qd_des[j] = 0.0
            if k == FB_HOLD:
                q_des[j] = fb[Q_HOLD, j]
                kp[j] = fb[HOLD_KP, j]
                kd[j] = fb[HOLD_KD, j]
                tau_ff[j] = min(max(fb[TAU_HOLD, j], -tmax), tmax)
            else:
                q_des[j] = q[j] if np.isfinite(q[j]) else 0.0
                kp[j] = 0.0
                kd[j] = fb[DAMP_KD, j] if k == FB_DAMP else 0.0
                tau_ff[j] = min(max(fb[TAU_HOLD, j], -tmax), tmax) if k == FB_DAMP else 0.0
        else:
            q_des[j] = 0.0
            qd_des[j] = 0.0
            kp[j] = 0.0
            kd[j] = 0.0
            if k == FB_HOLD:
                tau = fb[HOLD_KP, j] * (fb[Q_HOLD, j] - q[j]) - fb[HOLD_KD, j] * qd[j] + fb[TAU_HOLD, j]
            elif k == FB_DAMP:
                tau = -fb[DAMP_KD, j] * qd[j] + fb[TAU_HOLD, j]
            else:
                tau = 0.0
            tau_ff[j] = min(max(tau, -tmax), tmax)
    return speed
