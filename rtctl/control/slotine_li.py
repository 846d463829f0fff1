"""Slotine–Li adaptive control on the C* model (Huo, Gao & Cheng) or the classic Christoffel
model (Niemeyer & Slotine 1988); docs/cstar_slotine_li.md, the paper's equations (18)-(42).

    q̃ = q − q_d,  q̇_r = q̇_d − Λ q̃,  q̈_r = q̈_d − Λ (q̇ − q̇_d),  s = q̇ − q̇_r
    τ = Ĥ q̈_r + Ĉ q̇_r + Ĝ − K_D s                        (18) / (29), Ĉ = C (classic) or C* (cstar)
    dπ̂/dt = −P Yᵀ(q, q̇, q̇_r, q̈_r) s                      (19) / (30)

Both are computed by the O(n) recursions of :mod:`rtctl.control.slotine_li_kernels`, one
compiled call per tick. Λ, K_D diagonal (per joint); P diagonal (per link and parameter).

**Integration.** dπ̂/dt is integrated at the controller's rate by explicit Euler: tick k applies
π̂ ← π̂ + (t_k − t_{k−1}) · dπ̂/dt|_{k−1} and then computes τ_k with the new π̂ — the step is
the time actually elapsed since the previous update (period × divisor in a regular loop). A tick
whose state is stale on any joint (a drive's reply missed its deadline) contributes no
adaptation: its s is older than its regressor. How the sampling and the wire's delay bound the
gains: :mod:`rtctl.control.margins`.

**Options and the guarantees** (continuous time, exact model of the rigid body):
``V = ½ sᵀ H s + ½ π̃ᵀ P⁻¹ π̃`` has dV/dt = −sᵀ K_D s ≤ 0 (Proposition 2 makes this hold for
C* as for C), so s → 0, q̃ → 0 and π̂ stays bounded (not necessarily → π: that needs
persistent excitation).

* ``projection = True``: after each Euler step every link's π̂ is moved towards the physically
  consistent set (pseudo-inertia ⪰ 0, :mod:`rtctl.control.consistency`) by projections in the
  P⁻¹ metric onto half-spaces that contain that set. Each one is non-expansive towards the
  true π, so it never increases V: the argument above is intact, and Ĥ stays positive
  semidefinite (to the stated tolerance), so the feed-forward never has a negative mass.
* ``dead_zone = δ > 0``: adaptation stops while ‖s‖ ≤ δ. With bounded unmodelled torques d
  (noise, friction) and δ ≥ ‖d‖_max / λ_min(K_D), V decreases whenever it adapts, so π̂ cannot
  drift (parameter drift is what noise does to the plain law); the price is that s converges
  only into the ball ‖s‖ ≤ δ, i.e. a residual tracking error of about δ / λ_min(Λ) per joint,
  even with a perfect plant.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rtctl.control.base import Controller
from rtctl.control.gains import per_joint
from rtctl.control.tunable import Tunable
from rtctl.control.slotine_li_kernels import ARMATURE, CLASSIC, COULOMB, COULOMB_VELOCITY, CSTAR, \
    DEAD_ZONE, KD, LAM, LAW, MOTOR, PROJECT, STEP, TAU, VISCOUS, CUT_ROW, slotine_li_update_kernel, \
    work_rows
from rtctl.model import robot
from rtctl.model.data import BODY_SLOTS
from rtctl.model.dynamics import model_arrays

LAWS = {"cstar": CSTAR, "classic": CLASSIC}
PARAMS0 = ("true", "zeros", "scaled")


def initial_params(model, params0="true", params_scale=1.0) -> np.ndarray:
    """π̂(0) as an (n, 10) array: ``"true"`` (the model's), ``"zeros"``, ``"scaled"`` (the
    model's times ``params_scale``, one number or one per link), a path (``.npy`` with n × 10
    numbers, or ``.toml`` with ``params = [[10 numbers] × n]``), or an array."""
    n = model.nq
    if isinstance(params0, str) and params0 in PARAMS0:
        if params0 == "zeros":
            return np.zeros((n, 10))
        scale = np.broadcast_to(np.asarray(params_scale if params0 == "scaled" else 1.0, float), (n,))
        return model.params * scale[:, None]
    if isinstance(params0, (str, Path)):
        path = Path(params0)
        if path.suffix == ".npy":
            params0 = np.load(path)
        else:
            from rtctl.tomltable import load_toml

            t = load_toml(path)
            params0 = t.raw("params")
    p = np.array(params0, dtype=float).reshape(n, 10)
    if not np.all(np.isfinite(p)):
        raise ValueError("initial parameter estimates must be finite")
    return p


def adaptation_gains(gamma, n: int) -> np.ndarray:
    """P as (n, 10): one number, one per link, or 10 per link."""
    g = np.asarray(gamma, dtype=float)
    if g.ndim == 0:
        g = np.full((n, 10), float(g))
    elif g.shape == (n,):
        g = np.repeat(g[:, None], 10, axis=1)
    if g.shape != (n, 10) or np.any(g < 0) or not np.all(np.isfinite(g)):
        raise ValueError(f"gamma must be a number, {n} numbers or {n} × 10 numbers, all ≥ 0")
    return np.ascontiguousarray(g)


GAMMA_CLASSES = {"mass": slice(0, 1), "first_moment": slice(1, 4), "inertia": slice(4, 10)}


def _gamma_option(t, n: int):
    """``gamma``: a number, n numbers, n × 10 numbers, or a table by parameter class
    ``{mass = .., first_moment = .., inertia = ..}`` (each a number or n numbers)."""
    if not isinstance(t.raw("gamma"), dict):
        return t.raw("gamma")
    g, classes = np.zeros((n, 10)), t.table("gamma")
    for key, cols in GAMMA_CLASSES.items():
        g[:, cols] = per_joint(classes, key, n)[:, None]
    classes.done()
    return g


class SlotineLi(Controller):
    """The adaptive controller; ``law`` is ``"cstar"`` (the paper's) or ``"classic"``.

    ``lam`` (Λ) and ``kd`` (K_D): one number or one per joint; ``gamma`` (P): see
    :func:`adaptation_gains`; all three required (as in a configuration).
    ``params0``/``params_scale``: see :func:`initial_params`; ``motor_model``: add the robot
    file's armature and friction as known feed-forward.
    """

    def __init__(self, model, law="cstar", *, lam, kd, gamma, params0="true", joints=None, divisor=1,
                 projection=False, dead_zone=0.0, params_scale=1.0, motor_model=False, coulomb_velocity=robot.COULOMB_VELOCITY,
                 name="slotine_li"):
        super().__init__(name, model, joints, divisor)
        if law not in LAWS:
            raise ValueError(f"law must be one of {sorted(LAWS)}, got {law!r}")
        n = model.nq
        self.law, self.projection, self.dead_zone = law, bool(projection), float(dead_zone)
        motors = model.motors if motor_model else None
        self.motor_model = motors is not None
        self.settings = np.zeros(6)
        self.settings[[LAW, PROJECT, MOTOR, COULOMB_VELOCITY, DEAD_ZONE]] = (
            LAWS[law], self.projection, self.motor_model, coulomb_velocity, self.dead_zone)
        self.gains = np.zeros((5, n))
        self.gains[LAM], self.gains[KD] = lam, kd
        if motors is not None:
            self.gains[ARMATURE], self.gains[VISCOUS], self.gains[COULOMB] = (
                motors.armature, motors.viscous, motors.coulomb)
        self.lam, self.kd = self.gains[LAM], self.gains[KD]
        self.gamma = adaptation_gains(gamma, n)
        self.params0 = initial_params(model, params0, params_scale)
        self.params_hat = self.params0.copy()
        self.params_dot = np.zeros((n, 10))
        self.arrays = model_arrays(model)
        self.signals = np.zeros((4, n))  # q̇_r, q̈_r, s, τ
        self.qdr, self.qddr, self.s, self.tau = self.signals
        self._work = (np.zeros((n, 4, 3)), np.zeros((n, BODY_SLOTS, 6)), np.zeros((work_rows(n), 10)))
        self._scratch = (np.zeros((n, 4, 3)), np.zeros((n, BODY_SLOTS, 6)), np.zeros((work_rows(n), 10)),
                         np.zeros(6), np.zeros((4, n)), np.zeros((n, 10)), np.ones(n, dtype=bool), np.zeros((3, n)),
                         np.zeros(n, dtype=bool), np.zeros(n))  # (fresh, ref, no joint owned, τ out)
        self._t_prev = np.nan
        self.internals = {"params_hat": self.params_hat.reshape(-1), "s": self.s}

    @classmethod
    def from_config(cls, cfg, model):
        """Options: law, lam, kd, gamma, params0, params_scale, projection, dead_zone, motor_model."""
        t, n = cfg.options, model.nq
        params0 = t.str("params0", "true")
        if params0 not in PARAMS0:
            params0 = (t.file.parent / params0)
            if params0.suffix not in (".npy", ".toml") or not params0.exists():
                raise t.error("params0", f"one of {', '.join(PARAMS0)} or an existing .npy/.toml file")
        scale = per_joint(t, "params_scale", n, 1.0)
        try:
            gamma = adaptation_gains(_gamma_option(t, n), n)
            p0 = initial_params(model, params0, scale)
        except (ValueError, TypeError, OSError) as e:
            raise t.error("gamma" if "gamma" in str(e) else "params0", str(e)) from None
        c = cls(model, law=t.str("law", "cstar", choices=tuple(LAWS)), lam=per_joint(t, "lam", n),
                kd=per_joint(t, "kd", n), gamma=gamma, params0=p0, joints=cfg.joints, divisor=cfg.divisor,
                projection=t.bool("projection", False), dead_zone=t.float("dead_zone", 0.0, min=0.0),
                motor_model=t.bool("motor_model", False), name=cfg.name)
        t.done()
        return c

    def tunables(self) -> dict:
        n = self.model.nq
        return {"lam": Tunable(self.lam, lambda t, k: per_joint(t, k, n)),
                "kd": Tunable(self.kd, lambda t, k: per_joint(t, k, n))}

    def compute(self, q, qd, q_des, qd_des, qdd_des):
        """(τ, dπ̂/dt) for one tick at the current estimates; changes no state (allocates its
        result: use :meth:`update` in a loop)."""
        n = self.model.nq
        q, qd, *ref_rows = [np.ascontiguousarray(x, dtype=float).reshape(n) for x in (q, qd, q_des, qd_des, qdd_des)]
        X, body, work, settings, signals, params_dot, fresh, ref, owned, tau_out = self._scratch
        settings[:] = self.settings
        settings[STEP] = 0.0
        ref[:] = ref_rows
        m = self.arrays
        slotine_li_update_kernel(settings, m.joint, m.geom, self.params_hat, m.gravity, self.gains, self.gamma, X, body,
                                 work, q, qd, fresh, ref, signals, params_dot, owned, tau_out)
        return signals[TAU].copy(), params_dot.copy()

    def reset(self, state=None) -> None:
        """Restore π̂(0); the next update starts a fresh integration."""
        self.params_hat[:] = self.params0
        self.params_dot[:] = 0.0
        self._work[2][CUT_ROW:] = 0.0  # the projection's remembered cut directions
        self._t_prev = np.nan

    def resume(self, state=None) -> None:
        """Keep π̂ as it is; the next update starts a fresh integration (no step over the time
        the controller was inactive)."""
        self.params_dot[:] = 0.0
        self._t_prev = np.nan

    def update(self, t, state, ref, command):
        self.settings[STEP] = t - self._t_prev if self._t_prev == self._t_prev else 0.0  # nan ≠ nan: first update
        self._t_prev = t
        m, (X, body, work) = self.arrays, self._work
        slotine_li_update_kernel(self.settings, m.joint, m.geom, self.params_hat, m.gravity, self.gains, self.gamma, X,
                                 body, work, state.position, state.velocity, state.fresh, ref.packed, self.signals,
                                 self.params_dot, self.mask, command.tau_ff)
