"""The run-time guard: the safety stage's :class:`~rtctl.safety.Guard` hook behind the zones.

Every tick the controllers are in charge, :meth:`RuntimeGuard.check` runs the compiled
:func:`~rtctl.guard.kernels.guard_tick` on the measured state and the bounded command: the
robot's straight stopping path (one period at the current velocity, then braking within the
deceleration limits) must stay out of every zone inflated by the guard margin and inside the
joint limits. On a violation the configured action applies:

* ``"stop"`` — the stage latches a GUARD fault and its fallback (hold or damp) stops the arm;
* ``"clamp"`` — while the stopping path only enters the outer half of the guard margin, the
  command's component into the zone is removed and a wall pushes back, in proportion to how
  deep the predicted stop point lies in the band and to the inward speed (the robot slides
  along the zone instead of entering it; the controllers stay in charge). A stopping path
  that reaches the inner half stops as above.

A ``guard`` event naming the zone (or the limit) starts each episode; an episode ends after
:data:`QUIET_TICKS` ticks without a violation. Nothing is allocated unless an episode starts.
"""
from __future__ import annotations

import numpy as np

from rtctl.guard import kernels as k
from rtctl.guard.zones import Scene

QUIET_TICKS = 100
ACTIONS = ("stop", "clamp")


class RuntimeGuard:
    """``deceleration``: rad/s² (m/s²) per joint or one for all — what the stopping path may
    assume; ``dt``: the loop period; ``margin``: the guard margin (≥ 0, ≥ a hair for clamp);
    ``damping`` (N·m·s/rad) and ``stiffness`` (N·m/rad): the clamp's wall (the safety stage's
    hold gains, in a run)."""

    def __init__(self, scene: Scene, deceleration, dt: float, *, margin: float = 0.0, action: str = "stop",
                 damping: float = 5.0, stiffness: float = 50.0):
        n = scene.n
        decel = np.broadcast_to(np.asarray(deceleration, float), (n,))
        if not np.all(np.isfinite(decel) & (decel > 0)):
            raise ValueError("deceleration must be finite and > 0 for every joint")
        if not (np.isfinite(dt) and dt > 0) or not (np.isfinite(margin) and margin >= 0):
            raise ValueError("need dt > 0 and a finite guard margin >= 0")
        if action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, not {action!r}")
        if action == "clamp" and margin <= 0:
            raise ValueError("clamping needs a guard margin > 0 (it clamps in its outer half)")
        if not (np.isfinite(damping) and damping >= 0 and np.isfinite(stiffness) and stiffness >= 0):
            raise ValueError("damping and stiffness must be finite and >= 0")
        self.scene, self.action = scene, action
        lim = np.empty((k.N_LIMIT_ROWS, n))
        lim[k.Q_MIN], lim[k.Q_MAX], lim[k.DECEL] = scene.q_min, scene.q_max, decel
        par = np.zeros(k.N_PARAMS)
        par[k.DT], par[k.MARGIN], par[k.DAMPING], par[k.STIFFNESS] = dt, margin, damping, stiffness
        par[k.CLAMP] = 1.0 if action == "clamp" else 0.0
        self.F, self.I, views = k.pack(*scene.tables(), lim, par, np.zeros((k.N_WORK_ROWS, n)),
                                       np.zeros(k.N_REPORT, dtype=np.uint32))
        self.rows, self.cols, self.pieces, self.lim, self.par, self.work, self.report, self.hints = views
        self.reason = ""
        self.event_due = False  # True on the tick an episode starts (the stage emits the event)
        self._event: dict = {}
        self._quiet = QUIET_TICKS

    @property
    def margin(self) -> float:
        return float(self.par[k.MARGIN])

    @property
    def deceleration(self) -> np.ndarray:
        return self.lim[k.DECEL]

    def check(self, t: float, state, command) -> int:
        verdict = k.guard_tick_packed(state.position, state.velocity, int(command.mode), command.q_des,
                                      command.qd_des, command.tau_ff, self.F, self.I)
        if verdict == k.PASS:
            self._quiet += 1
            self.event_due = False
            return verdict
        self.event_due = self._quiet >= QUIET_TICKS
        self._quiet = 0
        if self.event_due or verdict == k.STOP:
            self._describe(state, verdict)
        return verdict

    def event(self) -> dict:
        """The fields of the ``guard`` event of the episode that just started."""
        return dict(self._event)

    def warm_up(self) -> None:
        """Run the compiled check once on scratch arrays (loads or compiles it)."""
        from rtctl.hal.joints import JointCommand, JointState

        n = self.scene.n
        state, command = JointState(n), JointCommand(n)
        state.position[:] = np.clip(0.0, self.scene.q_min, self.scene.q_max)
        k.guard_tick_packed(state.position, state.velocity, int(command.mode), command.q_des, command.qd_des,
                            command.tau_ff, self.F.copy(), self.I.copy())

    def _describe(self, state, verdict) -> None:
        kind, which = int(self.report[k.KIND]), int(self.report[k.WHICH])
        names = self.scene.joint_names
        if kind == k.ZONE:
            zone = self.scene.zones[which].name
            what = f"zone {zone!r}"
        else:
            zone = f"{names[which]} {'upper' if kind == k.UPPER_LIMIT else 'lower'} limit"
            what = f"the {zone}"
        action = "stop" if verdict == k.STOP else "clamp"
        stop_point = self.work[k.STOP_POINT].tolist()
        self.reason = (f"guard: the stopping path from q = [{', '.join(f'{x:.4g}' for x in state.position)}] "
                       f"would enter {what} (predicted stop at [{', '.join(f'{x:.4g}' for x in stop_point)}])")
        self._event = {"zone": zone, "action": action, "q": state.position.tolist(),
                       "qd": state.velocity.tolist(), "stop_point": stop_point, "reason": self.reason}
