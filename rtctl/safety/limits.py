"""The limits the safety stage enforces, as one preallocated table (rows: kernels.HARD_LO …).

Policy (chosen here, applied by :mod:`rtctl.safety.kernels`):

* **Position** — two bands. Between the *soft* limit (``position_margin`` inside the joint
  range) and the *hard* limit (the joint range itself) the command is clamped: a torque that
  would push the joint further out is zeroed, one that brings it back passes (so does
  gravity: the stage does not pretend to hold an arm it cannot model). Past the hard limit
  the stage faults and the fallback holds the joint where it is. With a margin of 0 both
  bands coincide: clamp at the limit, fault beyond it.
* **Velocity** — |q̇| above ``velocity_factor`` · v_max is a fault (a runaway is not clamped
  away by a torque bound).
* **Torque** — clamped to ±tau_max and counted (not a fault: saturation is normal).
* **Following error** — while the controllers are in charge of a reference, a joint more
  than ``following_error`` from it for ``following_ticks`` consecutive ticks is a fault (as a
  drive's following-error window, CiA 402 0x6065/0x6066): a controller that has lost the
  robot — diverging estimates, a wrong model, a saturated drive — is stopped before a limit
  has to catch it. Off (∞) unless configured: the window is the robot's and the job's.
* **Impedance mode** — gains kp ∈ [0, kp_max], kd ∈ [0, kd_max]; q_des inside the soft
  limits; |qd_des| ≤ v_lim; tau_ff shifted so the torque the drive would produce at the
  current state obeys the two rules above. The drive closes the loop faster than the tick,
  so this bounds the command at the state the stage saw, not every torque in between — the
  drive's own torque limit (and its command-timeout watchdog) covers the rest.
"""
from __future__ import annotations

import numpy as np

from rtctl.safety.kernels import (FOLLOW, HARD_HI, HARD_LO, KD_MAX, KP_MAX, N_LIMIT_ROWS, SOFT_HI, SOFT_LO,
                                  TAU_MAX, V_LIM)


def limits_table(q_min, q_max, v_max, tau_max, *, position_margin=0.0, velocity_factor: float = 1.0,
                 kp_max=np.inf, kd_max=np.inf, following_error=np.inf) -> np.ndarray:
    """(9, n) table of hard/soft position limits, velocity, torque, impedance-gain bounds and
    the following-error window."""
    q_min, q_max, v_max, tau_max = (np.asarray(x, float) for x in (q_min, q_max, v_max, tau_max))
    n = q_min.shape[0] if q_min.ndim == 1 else -1
    if n < 0 or not all(x.shape == (n,) for x in (q_max, v_max, tau_max)):
        raise ValueError("q_min, q_max, v_max and tau_max need one value per joint")
    if np.any(q_min >= q_max) or np.any(v_max <= 0) or np.any(tau_max <= 0) or velocity_factor <= 0:
        raise ValueError("need q_min < q_max, v_max > 0, tau_max > 0, velocity_factor > 0")
    margin = np.broadcast_to(np.asarray(position_margin, float), (n,))
    if np.any(margin < 0) or np.any(q_min + margin > q_max - margin):
        raise ValueError("position_margin must be >= 0 and leave a non-empty range")
    lim = np.empty((N_LIMIT_ROWS, n))
    lim[HARD_LO], lim[HARD_HI] = q_min, q_max
    lim[SOFT_LO], lim[SOFT_HI] = q_min + margin, q_max - margin
    lim[V_LIM] = velocity_factor * v_max
    lim[TAU_MAX] = tau_max
    lim[KP_MAX] = kp_max
    lim[KD_MAX] = kd_max
    lim[FOLLOW] = following_error
    if np.any(lim[KP_MAX] < 0) or np.any(lim[KD_MAX] < 0):
        raise ValueError("kp_max and kd_max must be >= 0")
    if not np.all(lim[FOLLOW] > 0):
        raise ValueError("following_error must be > 0 (inf: no check)")
    return lim
