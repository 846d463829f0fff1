"""The Qu–Jiang adaptive controller: per joint an ARX model whose coefficients and "virtual
noise" statistics the Sage–Husa filter identifies every sample (:mod:`rtctl.estimation`),
and the GMV law (:mod:`rtctl.control.gmv`) on the current estimates. docs/arma_kalman.md.

Each update (every ``divisor`` ticks: T = divisor / rate), per owned joint i, in one compiled call
(six array arguments: numba's dispatcher costs about 0.1 µs per argument, a third of the update):

1. y(k) = q_i; the filter steps with h(k) from the histories (skipped on the first update
   after a reset, which only starts the histories: y from the measured position, u = 0);
2. y*(k+d) = q_d + q̇_d τ + ½ q̈_d τ², τ = d·T (the reference previewed d samples ahead from
   its derivatives; T measured as the time since the previous update);
3. u(k) from (30), saturated at the joint's torque limit; the saturated u(k) enters the
   histories (anti-windup) and the command, held until the next update.

A non-finite measurement, reference, estimate or torque makes ``update`` raise
:class:`~rtctl.errors.ControllerError` naming the joint and the quantity, before anything is
written to the command (the safety stage takes over in the same tick).

Telemetry (``internals``): ``a_hat`` (na, m), ``b_hat`` (nb + 1, m), ``r_hat``, ``R_hat``,
``eps`` (the innovation ε), ``u`` (the GMV torque), each per owned joint.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.compiled import kernel, leaf
from rtctl.control.base import Controller
from rtctl.control.gmv import gmv_law, gmv_phi
from rtctl.control.tunable import Tunable
from rtctl.errors import ControllerError
from rtctl.estimation.arx import MAX_ORDER, ArxOrder, push_history, regressor_into
from rtctl.estimation.sage_husa import (N_SWITCHES, NOISE_FORMS, QUANTITIES, SWITCH_NAMES, SageHusa, first_nonfinite,
                                        sage_husa_step, state_views)

# int settings: the filter's switches, then the order, then the owned joints
NA, NB, D, PRIMED, JOINTS = range(N_SWITCHES, N_SWITCHES + 5)
# float settings
LAM, R_MIN, HORIZON = range(3)
N_FLOAT_SETTINGS = 3
# per-joint rows
RHO, U_MAX = range(2)
# scratch rows
H_ROW, PH_ROW, OLD_ROW, PRED_ROW = range(4)
FAILURES = QUANTITIES + ("torque u", "measured position y", "reference y*")
_STRIDE = 16


@leaf
def work_views(work, m, na, memory, width):
    """(fset, joint_params, y_hist, u_hist, scratch) as views of the controller's ``work``
    array: float settings, per-joint ρ and u_max (2, m), the histories (na, m) and
    (memory, m), scratch rows (4, width)."""
    a = N_FLOAT_SETTINGS
    b = a + 2 * m
    c = b + na * m
    e = c + memory * m
    return (work[:a], work[a:b].reshape((2, m)), work[b:c].reshape((na, m)), work[c:e].reshape((memory, m)),
            work[e:e + 4 * width].reshape((4, width)))


@kernel
def arma_gmv_kernel(iset, position, ref, filter_state, work, tau):
    """One controller update over the owned joints (``iset[JOINTS:]``; ``ref``: rows q, q̇, q̈);
    returns 0 or 1 + 16·(local joint) + the index of the failing quantity in :data:`FAILURES`
    (nothing written for that joint then)."""
    na, nb, d = iset[NA], iset[NB], iset[D]
    joints = iset[JOINTS:]
    m, p = joints.shape[0], na + nb + 1
    theta, P, drift, signals, fade = state_views(filter_state, m, p)
    fset, joint_params, y_hist, u_hist, scratch = work_views(work, m, na, d + nb, max(p, d))
    ref_q, ref_qd, ref_qdd = ref[0], ref[1], ref[2]
    h, Ph, old, y_pred = scratch[H_ROW, :p], scratch[PH_ROW, :p], scratch[OLD_ROW, :p], scratch[PRED_ROW]
    tau_h = fset[HORIZON]
    for i in range(joints.shape[0]):
        j = joints[i]
        y = position[j]
        if not np.isfinite(y):
            return 1 + _STRIDE * i + 7
        y_star = ref_q[j] + ref_qd[j] * tau_h + 0.5 * ref_qdd[j] * tau_h * tau_h
        if not np.isfinite(y_star):
            return 1 + _STRIDE * i + 8
        if iset[PRIMED]:
            regressor_into(i, y_hist, u_hist, d, h)
            sage_husa_step(i, theta, P, drift[0], drift[1], signals, fade, h, y, fset[LAM], iset, fset[R_MIN],
                           drift[2], Ph, old)
            bad = first_nonfinite(i, theta, P, drift[0], drift[1], signals)
            if bad >= 0:
                return 1 + _STRIDE * i + bad
        phi = gmv_phi(i, theta, signals[0, i], y, y_hist, u_hist, na, d, y_pred)
        u = gmv_law(theta[na, i], phi, y_star, joint_params[RHO, i], u_hist[0, i], joint_params[U_MAX, i])
        if not np.isfinite(u):
            return 1 + _STRIDE * i + 6
        push_history(i, y_hist, u_hist, y, u)
        tau[j] = u
    iset[PRIMED] = 1
    return 0


class ArmaGmv(Controller):
    """ARX(na, nb, d) per joint + Sage–Husa identification + GMV.

    ``rho`` (ρ > 0) and ``r0``, ``R0``: a number or one per owned joint; ``theta0``, ``P0``
    (diagonal of P(0)), ``q0``, ``Q0`` (diagonal of Q̂(0)), ``Q_min``: a number, na + nb + 1
    numbers, or one such row per owned joint; ``adapt``: the switched-on adaptations among
    ``"r", "R", "q", "Q"``; the rest as :class:`~rtctl.estimation.sage_husa.SageHusa`.
    Defaults (also for the options a configuration leaves out): na = nb = 2, d = 1, λ = 0.98,
    r0 = q0 = Q0 = Q_min = 0, R0 = 10⁻⁸, R_min = 10⁻¹², r̂ and R̂ adapted, the ``"sage_husa"``
    form, ``divisor`` 1.
    """

    def __init__(self, model, *, theta0, P0, rho, order: ArxOrder = ArxOrder(), lam=0.98, r0=0.0, R0=1e-8, q0=0.0,
                 Q0=0.0, Q_min=0.0, R_min=1e-12, adapt=("r", "R"), forget_covariance=False, noise_form="sage_husa",
                 joints=None, divisor=1, name="arma_gmv"):
        super().__init__(name, model, joints, divisor)
        m = len(self.joints)
        self.order = order
        self.filter = SageHusa(m, order.p, lam=lam, theta0=theta0, P0=P0, r0=r0, R0=R0, q0=q0, Q0=Q0, adapt=adapt,
                               R_min=R_min, Q_min=Q_min, forget_covariance=forget_covariance, noise_form=noise_form)
        f = self.filter
        width = max(order.p, order.d)
        self.work = np.zeros(N_FLOAT_SETTINGS + (2 + order.na + order.memory) * m + 4 * width)
        self.fset, self.joint_params, self.y_hist, self.u_hist, self.scratch = work_views(
            self.work, m, order.na, order.memory, width)
        rho = np.broadcast_to(np.asarray(rho, dtype=float), (m,))
        if not np.all(rho > 0) or not np.all(np.isfinite(rho)):
            raise ValueError(f"rho must be finite and > 0, got {rho.tolist()}")
        self.joint_params[RHO] = rho
        tau_max = model.tau_max[self.joints]
        self.joint_params[U_MAX] = np.where(np.isfinite(tau_max), tau_max, 1e300)
        self.iset = np.zeros(JOINTS + m, dtype=np.int64)
        self.iset[:N_SWITCHES] = f.switches
        self.iset[NA], self.iset[NB], self.iset[D] = order.na, order.nb, order.d
        self.iset[JOINTS:] = self.joints
        self.fset[LAM], self.fset[R_MIN] = f.lam, f.R_min
        self._t_prev = math.nan
        self.internals = {"a_hat": f.theta[:order.na], "b_hat": f.theta[order.na:], "r_hat": f.r_hat,
                          "R_hat": f.R_hat, "eps": f.eps, "u": self.u_hist[0]}
        self.reset()

    @classmethod
    def from_config(cls, cfg, model):
        """Options: na, nb, d, lam, rho, adapt = {r, R, q, Q}, theta0, P0, r0, R0, q0, Q0, Q_min,
        R_min, forget_covariance, noise_form (docs/arma_kalman.md)."""
        t, m = cfg.options, len(cfg.joints)
        order = ArxOrder(*(t.int(k, default, min=1, max=MAX_ORDER[k]) for k, default in (("na", 2), ("nb", 2), ("d", 1))))
        lam = t.float("lam", 0.98)
        if not 0.0 < lam < 1.0:
            raise t.error("lam", f"a number in (0, 1), got {lam!r}")
        switches = {"r": True, "R": True, "q": False, "Q": False}
        adapt_t = t.table("adapt", None)
        if adapt_t is not None:
            switches = {k: adapt_t.bool(k, v) for k, v in switches.items()}
            adapt_t.done()
        c = cls(model, order=order, lam=lam, rho=_per_joint(t, "rho", m, positive=True),
                theta0=_rows(t, "theta0", m, order.p), P0=_rows(t, "P0", m, order.p, nonnegative=True),
                r0=_per_joint(t, "r0", m, 0.0), R0=_per_joint(t, "R0", m, 1e-8, nonnegative=True),
                q0=_rows(t, "q0", m, order.p, default=0.0), Q0=_rows(t, "Q0", m, order.p, 0.0, nonnegative=True),
                Q_min=_rows(t, "Q_min", m, order.p, 0.0, nonnegative=True),
                R_min=t.float("R_min", 1e-12, positive=True), adapt=tuple(k for k in SWITCH_NAMES if switches[k]),
                forget_covariance=t.bool("forget_covariance", False),
                noise_form=t.str("noise_form", "sage_husa", choices=NOISE_FORMS), joints=cfg.joints,
                divisor=cfg.divisor, name=cfg.name)
        t.done()
        return c

    def tunables(self) -> dict:
        m = len(self.joints)
        return {"rho": Tunable(self.joint_params[RHO], lambda t, k: _per_joint(t, k, m, positive=True))}

    def reset(self, state=None) -> None:
        """Initial estimates; histories start at the measured position (``state``; 0 without
        one) with u = 0."""
        f = self.filter
        f.reset()
        self.u_hist[:] = 0.0
        self.y_hist[:] = 0.0 if state is None else state.position[self.joints]
        self.iset[PRIMED] = 0
        self._t_prev = math.nan

    def resume(self, state=None) -> None:
        """Keep θ̂, P and the noise statistics; restart the histories from ``state`` (the
        samples before the controller was inactive say nothing of now; 0 without a state)."""
        self.u_hist[:] = 0.0
        self.y_hist[:] = 0.0 if state is None else state.position[self.joints]
        self.iset[PRIMED] = 0
        self._t_prev = math.nan

    def update(self, t, state, ref, command):
        f = self.filter
        self.fset[HORIZON] = self.order.d * (t - self._t_prev) if self._t_prev == self._t_prev else 0.0
        self._t_prev = t
        code = arma_gmv_kernel(self.iset, state.position, ref.packed, f.state, self.work, command.tau_ff)
        if code:
            i, what = divmod(code - 1, _STRIDE)
            joint = self.model.joint_names[self.joints[i]]
            raise ControllerError(f"joint {joint!r}: non-finite {FAILURES[what]}")


def _per_joint(t, key, m, default=None, *, positive=False, nonnegative=False) -> np.ndarray:
    """A finite number (every owned joint) or ``m`` finite numbers."""
    raw = t.raw(key, default)
    if raw is None:
        raise t.error(key, f"missing; expected a number or {m} numbers (one per joint)")
    values = t.vector(key, m) if isinstance(raw, list) else np.full(m, t.float(key, default))
    if (positive and not np.all(values > 0)) or (nonnegative and not np.all(values >= 0)):
        raise t.error(key, f"numbers {'> 0' if positive else '≥ 0'}, got {raw!r}")
    return values


def _rows(t, key, m, p, default=None, *, nonnegative=False) -> np.ndarray:
    """A finite number, ``p`` finite numbers (every owned joint), or ``m`` rows of ``p`` → (m, p)."""
    raw = t.raw(key, default)
    expected = f"a number, {p} numbers (na + nb + 1) or {m} arrays of {p} (one per joint)"
    if raw is None:
        raise t.error(key, f"missing; expected {expected}")
    if not isinstance(raw, list):
        rows = np.full((m, p), t.float(key, default))
    elif raw and all(isinstance(r, list) for r in raw):
        if len(raw) != m:
            raise t.error(key, f"{expected}, got {len(raw)} arrays")
        rows = np.array([_row(t, f"{key}[{i}]", r, p) for i, r in enumerate(raw)])
    else:
        rows = np.tile(_row(t, key, raw, p), (m, 1))
    if nonnegative and np.any(rows < 0):
        raise t.error(key, f"numbers ≥ 0, got {raw!r}")
    return rows


def _row(t, key, raw, p) -> np.ndarray:
    ok = len(raw) == p and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in raw)
    if not ok:
        raise t.error(key, f"{p} finite numbers (na + nb + 1), got {raw!r}")
    return np.array(raw, dtype=float)
