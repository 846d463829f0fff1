"""The safety stage (docs/architecture.md, "The tick"): every tick, after the controllers and before ``write()``.

It checks the measured state (limits, non-finite values, stale data, device status, and the
following error against the reference when one is given), bounds
the controllers' command in place (:mod:`rtctl.safety.limits`), runs the interference
guard's hook, and on any fault takes over *in the same tick*: faults latch, the stage writes
the fallback command and says so in its :class:`Verdict`, so a drive is never left enabled
without something in charge of it.

Stops:

* an ordinary fault (limit, following error, non-finite or raising controller, stale data,
  device ERROR, guard) engages the configured fallback — ``"hold"`` (PD to where the robot was at the
  fault, with damping) or ``"damp"`` (τ = −D q̇) — and keeps the drives enabled (stop
  category 2, IEC 60204-1) until ``reset()``, or for ``fault_off_delay`` s if finite, after
  which the verdict turns DEACTIVATE;
* an e-stop (``estop()``) or a device asking to be deactivated is a category-1 stop:
  damping, then DEACTIVATE once every joint is slower than ``stop_velocity`` or after
  ``estop_off_delay`` s, whichever comes first (``estop_off_delay = 0``: category 0);
* a normal end (``stop()``: the duration reached, ``rtctl stop``, SIGTERM) stops the same
  way but is not a fault: nothing latches, the event is ``stop`` at info level, and
  :meth:`summary` reports it under ``stop`` with ``faulted`` false.

``reset()`` clears each latched fault whose cause is gone (position back in range, data
fresh again, device OK …; e-stops, controller and following-error faults are cleared by the
reset itself — the loop then holds where the robot is, so the reference is there too).
"""
from __future__ import annotations

import math

import numpy as np
import structlog

from rtctl.safety import kernels as k
from rtctl.safety.faults import STOPPING, Fault, FaultKind, GuardVerdict, Verdict, device_reason
from rtctl.safety.limits import limits_table

log = structlog.get_logger("rtctl.safety")

_MAX_EVENTS = 1000
_STATE_KINDS = (FaultKind.NONFINITE_STATE, FaultKind.POSITION, FaultKind.VELOCITY, FaultKind.FOLLOWING,
                FaultKind.STALE, FaultKind.DEVICE_ERROR, FaultKind.DEVICE_DEACTIVATE)
_DEVICE_KINDS = FaultKind.DEVICE_ERROR | FaultKind.DEVICE_DEACTIVATE


class SafetyStage:
    """Limits, watchdog, fallback, e-stop and guard hook for one robot's n joints.

    ``device_joints``: for each device, in the order of the ``statuses`` given to
    :meth:`check`, the indices of its joints (default: one device with all joints).
    ``gravity``: optional ``q -> τ_g`` evaluated once at a fault, added to the hold.
    ``guard``: optional :class:`~rtctl.safety.faults.Guard`. ``on_event``: optional callable
    receiving every event dict (also logged on the structlog logger ``rtctl.safety``).
    ``devices`` (in the order of ``device_joints``; objects with ``name``, ``fault_cause()`` and
    optionally ``stale_cause()``, as :class:`~rtctl.hal.JointGroup`) and ``joint_names`` make
    every fault's reason name the device and the joint by their configured names, and the
    cause as the driver saw it (asked only when a fault is recorded); without them, indices.
    Scalars or one value per joint for the gains, ``position_margin`` and ``following_error``
    (rad or m; ∞: no following-error check).
    """

    def __init__(self, q_min, q_max, v_max, tau_max, *, fallback: str = "hold", hold_stiffness=50.0,
                 damping=5.0, stale_ticks: int = 3, position_margin=0.0, velocity_factor: float = 1.0,
                 kp_max=np.inf, kd_max=np.inf, following_error=np.inf, following_ticks: int = 10,
                 estop_off_delay: float = 0.2, fault_off_delay: float = math.inf, stop_velocity: float = 0.01,
                 device_joints=None, gravity=None, guard=None, on_event=None, devices=None, joint_names=None):
        self.lim = limits_table(q_min, q_max, v_max, tau_max, position_margin=position_margin,
                                velocity_factor=velocity_factor, kp_max=kp_max, kd_max=kd_max,
                                following_error=following_error)
        n = self.lim.shape[1]
        if fallback not in ("hold", "damp"):
            raise ValueError(f"fallback must be 'hold' or 'damp', not {fallback!r}")
        if stale_ticks < 1 or following_ticks < 1 or estop_off_delay < 0 or fault_off_delay < 0 or stop_velocity < 0:
            raise ValueError("need stale_ticks >= 1, following_ticks >= 1 and non-negative delays and stop_velocity")
        self.n = n
        self.fallback_kind = k.FB_HOLD if fallback == "hold" else k.FB_DAMP
        self.fb = np.zeros((k.N_FALLBACK_ROWS, n))
        self.fb[k.HOLD_KP] = hold_stiffness
        self.fb[k.HOLD_KD] = damping
        self.fb[k.DAMP_KD] = damping
        if np.any(self.fb[:k.Q_HOLD] < 0):
            raise ValueError("hold_stiffness and damping must be >= 0")
        self.stale_ticks = int(stale_ticks)
        self.following_ticks = int(following_ticks)
        self.estop_off_delay = float(estop_off_delay)
        self.fault_off_delay = float(fault_off_delay)
        self.stop_velocity = float(stop_velocity)
        groups = [np.arange(n)] if device_joints is None else [np.asarray(g, dtype=np.int64) for g in device_joints]
        if sorted(np.concatenate(groups).tolist()) != list(range(n)):
            raise ValueError("device_joints must name every joint exactly once")
        self.iw = np.zeros((k.N_INT_ROWS, n + 1), dtype=np.int64)  # counters, flags, latched bits
        for d, g in enumerate(groups):
            self.iw[k.DEVICE, g] = d
        self.device_of_joint = self.iw[k.DEVICE, :n]
        if devices is not None and len(devices) != len(groups):
            raise ValueError(f"devices: one per group of device_joints ({len(groups)}), got {len(devices)}")
        if joint_names is not None and len(joint_names) != n:
            raise ValueError(f"joint_names: one per joint ({n}), got {len(joint_names)}")
        self.devices = None if devices is None else list(devices)
        self.joint_names = None if joint_names is None else tuple(joint_names)
        self._device_first = np.array([g.min() for g in groups])
        self.gravity = gravity
        self.guard = guard
        self.on_event = on_event
        self.log_events = True  # False for a stage that only warms the compiled paths up

        self._ok_statuses = np.zeros(len(groups), dtype=np.int64)
        self.faults: list[Fault] = []  # latched, oldest first
        self.events: list[dict] = []
        self.events_dropped = 0
        self._latched = self.iw[k.LATCHED]  # fault bits per joint, [n]: robot-wide
        self._clear_latch()
        self._t, self._tick = 0.0, 0
        self.stop_reason: str | None = None  # set by stop(): the run is ending normally
        self._state = None
        self._reference = None
        self._statuses = self._ok_statuses

    @classmethod
    def from_model(cls, model, config=None, **options) -> "SafetyStage":
        """Limits from the model (q_min/q_max/v_max/tau_max); settings from ``config`` (any
        object with attributes named like this class's keywords, e.g. rtctl.config's
        SafetyConfig) and ``options``, which win."""
        names = ("fallback", "hold_stiffness", "damping", "stale_ticks", "position_margin", "velocity_factor",
                 "kp_max", "kd_max", "following_error", "following_ticks", "estop_off_delay", "fault_off_delay",
                 "stop_velocity")
        kw = {a: getattr(config, a) for a in names if hasattr(config, a)}
        kw["joint_names"] = getattr(model, "joint_names", None)
        kw.update(options)
        return cls(model.q_min, model.q_max, model.v_max, model.tau_max, **kw)

    # -- every tick ----------------------------------------------------------------------
    def check(self, t: float, tick: int, state, statuses, command, controller_ok: bool = True,
              controller_error: str | None = None, reference=None, device_error: str | None = None) -> Verdict:
        """Check ``state``, bound or replace ``command`` in place, and return the verdict.

        ``statuses``: per device, this tick's read (or write) status as an int64 array (None:
        all OK). ``controller_ok=False`` (a controller raised; ``controller_error`` says how)
        engages the fallback this tick. ``reference``: the positions the controllers track this
        tick (None: no following-error check, and its counts restart). ``device_error``: the
        reason of a device without joints that failed this tick (a framegrabber, an I/O board;
        :func:`~rtctl.safety.faults.device_reason`): a DEVICE_ERROR, the fallback this tick.
        Allocates nothing while no fault is latched.
        """
        if reference is not None and (reference.ndim != 1 or len(reference) != self.n):
            raise ValueError(f"reference: one position per joint ({self.n}) expected")
        self._t = t
        self._tick = tick
        self._state = state
        self._reference = reference
        if statuses is None:
            statuses = self._ok_statuses
        self._statuses = statuses
        q, qd = state.position, state.velocity
        bound = controller_ok and not self._faulted
        follow = bound and not self._stopping and reference is not None
        mode = int(command.mode)
        found = k.check_tick(q, qd, state.fresh, statuses, self.lim, self.iw, self.stale_ticks,
                             q if reference is None else reference, follow, self.following_ticks, bound, mode,
                             command.q_des, command.qd_des, command.kp, command.kd, command.tau_ff)
        if found == k.NEW_STATE_FAULT:
            self._latch_state_faults(q, qd, statuses)
        elif found == k.NONFINITE_COMMAND_FOUND:
            self._latch_nonfinite_command(command, "")
        if not controller_ok:
            self._latch(FaultKind.CONTROLLER, -1, math.nan, controller_error or "a controller raised")
        if device_error is not None:
            self._latch(FaultKind.DEVICE_ERROR, -1, math.nan, device_error)
        if bound and not self._faulted and not self._stopping and self.guard is not None:
            self._run_guard(t, state, command, mode)
        if not (self._faulted or self._stopping):
            return Verdict.OK
        return self._fallback(t, qd, command)

    def _run_guard(self, t, state, command, mode):
        try:
            g = self.guard.check(t, state, command)
        except Exception as e:
            self._latch(FaultKind.GUARD, -1, math.nan, f"guard raised {type(e).__name__}: {e}")
            return
        if g != GuardVerdict.PASS and getattr(self.guard, "event_due", False):
            self._event("guard", "warning", **self.guard.event())  # an episode starts: which zone, what it did
        if g == GuardVerdict.STOP:
            self._latch(FaultKind.GUARD, -1, math.nan, getattr(self.guard, "reason", "") or "guard stop")
        elif g == GuardVerdict.MODIFIED:
            if k.bound_command(mode, state.position, state.velocity, command.q_des, command.qd_des,
                               command.kp, command.kd, command.tau_ff, self.lim, self.iw) >= 0:
                self._latch_nonfinite_command(command, " (written by the guard)")

    def _fallback(self, t, qd, command) -> Verdict:
        args = (self._state.position, qd, command.q_des, command.qd_des, command.kp, command.kd,
                command.tau_ff, self.lim, self.fb)
        if not self._deactivated:
            kind = k.FB_DAMP if self._stopping else self.fallback_kind
            speed = k.fallback(int(command.mode), kind, *args)
            if self._stopping:
                done = t - self._t_stop >= self.estop_off_delay or speed < self.stop_velocity
            else:
                done = t - self._t_fault >= self.fault_off_delay
            if not done:
                return Verdict.FALLBACK
            self._deactivated = True
            self._event("deactivate", "warning" if self._faulted else "info",
                        reason="stopped" if self._stopping else "fault_off_delay")
        k.fallback(int(command.mode), k.FB_OFF, *args)
        return Verdict.DEACTIVATE

    # -- operator actions (between ticks) ------------------------------------------------
    def estop(self, reason: str = "operator") -> None:
        """Latch an e-stop (category 1, see the module doc); takes effect at the next check()."""
        self._latch(FaultKind.ESTOP, -1, math.nan, reason)

    def stop(self, reason: str) -> None:
        """Begin a controlled stop that is not a fault (the run's normal end): damping that
        carries the arm's weight, then DEACTIVATE, as an e-stop; nothing latches. Takes effect
        at the next check(); a second call changes nothing."""
        if self.stop_reason is not None:
            return
        self.stop_reason = reason
        self._event("stop", "info", reason=reason)
        if not self._stopping:
            self._stopping = True
            self._t_stop = self._t
            if not self._faulted:
                self._snapshot_hold()

    def reset(self) -> bool:
        """Clear the latched faults whose cause is gone; True when none is left. After True,
        the loop resets its controllers (and re-activates the devices if it had deactivated
        them) before they take over again. After stop() it changes nothing: the run is ending."""
        if self.stop_reason is not None:
            return False
        keep = [f for f in self.faults if not self._cause_gone(f)]
        cleared = [f for f in self.faults if f not in keep]
        self._event("reset", "warning", cleared=[f.kind.name.lower() for f in cleared],
                    remaining=[f.as_dict() for f in keep])
        if keep:
            self.faults = keep
            self._latched[:] = 0
            for f in keep:
                self._latched[f.joint if f.joint >= 0 else self.n] |= f.kind
            self._stopping = any(f.kind & STOPPING for f in keep)
            return False
        self.faults = []
        self._clear_latch()
        return True

    # -- queries -------------------------------------------------------------------------
    @property
    def faulted(self) -> bool:
        return self._faulted

    @property
    def deactivated(self) -> bool:
        return self._deactivated

    def tunables(self) -> dict:
        """The fallback's gains, which ``rtctl set safety.…`` may change (read as in ``[safety]``)."""
        from rtctl.control.tunable import Tunable

        def damping(value):
            self.fb[k.HOLD_KD] = value
            self.fb[k.DAMP_KD] = value

        return {"hold_stiffness": Tunable(self.fb[k.HOLD_KP], lambda t, key: t.float(key, min=0.0)),
                "damping": Tunable(self.fb[k.HOLD_KD], lambda t, key: t.float(key, min=0.0), damping)}

    def summary(self) -> dict:
        """JSON-able (non-finite values stay floats: serialise with :mod:`rtctl.jsonout`):
        latched faults, the normal stop if one began, events, clamp counts per joint."""
        return {
            "faulted": self._faulted, "deactivated": self._deactivated,
            "stop": None if self.stop_reason is None else {"reason": self.stop_reason, "t": self._t_stop},
            "faults": [f.as_dict() for f in self.faults],
            "events": list(self.events), "events_dropped": self.events_dropped,
            "clamps": {"torque": self.iw[k.CLAMP_TORQUE, :self.n].tolist(),
                       "position": self.iw[k.CLAMP_POSITION, :self.n].tolist(),
                       "impedance": self.iw[k.CLAMP_IMPEDANCE, :self.n].tolist()},
        }

    # -- fault bookkeeping (rare path: may allocate) --------------------------------------
    def _clear_latch(self):
        self._latched[:] = 0
        self.iw[k.FOLLOW_COUNT] = 0  # the reference is re-planned where the robot is
        self._faulted = False
        self._deactivated = False
        self._stopping = False
        self._t_fault = math.nan
        self._t_stop = math.nan
        self.fb[k.Q_HOLD] = np.nan
        self.fb[k.TAU_HOLD] = 0.0

    def _latch_state_faults(self, q, qd, statuses):
        lim, flags, stale = self.lim, self.iw[k.FLAGS, :self.n], self.iw[k.STALE_COUNT]
        for j in np.flatnonzero(flags):
            f = int(flags[j])
            d = int(self.device_of_joint[j])
            for kind in _STATE_KINDS:
                if not f & kind or (kind & _DEVICE_KINDS and j != self._device_first[d]):
                    continue  # a device fault is recorded once, at the device's first joint
                joint = self._joint_label(j)
                if kind == FaultKind.POSITION:
                    value, why = q[j], f"{joint} at {q[j]:.6g} outside [{lim[k.HARD_LO, j]:.6g}, {lim[k.HARD_HI, j]:.6g}]"
                elif kind == FaultKind.VELOCITY:
                    value, why = qd[j], f"{joint}: velocity {qd[j]:.6g} beyond ±{lim[k.V_LIM, j]:.6g}"
                elif kind == FaultKind.NONFINITE_STATE:
                    value = q[j] if not np.isfinite(q[j]) else qd[j]
                    why = f"{joint} reported a non-finite state"
                elif kind == FaultKind.FOLLOWING:
                    e = self._reference[j] - q[j]
                    value, why = e, (f"{joint}: following error {e:.6g} beyond ±{lim[k.FOLLOW, j]:.6g} for "
                                     f"{self.following_ticks} ticks (reference {self._reference[j]:.6g})")
                elif kind == FaultKind.STALE:
                    value, why = stale[j], f"{joint}: no fresh data for {stale[j]} ticks{self._stale_cause(d)}"
                else:
                    value, why = statuses[d], self._device_reason(d, int(statuses[d]))
                self._latch(kind, int(j), float(value), why)
        self._latched[:self.n] |= flags  # seen: the other joints of a faulty device need no record

    def _joint_label(self, j: int) -> str:
        """``joint 2 (elbow) of device arm``, or ``joint 2`` without names (fault path: allocates)."""
        label = f"joint {j}" if self.joint_names is None else f"joint {j} ({self.joint_names[j]})"
        if self.devices is not None:
            label += f" of device {self.devices[int(self.device_of_joint[j])].name}"
        return label

    def _device_reason(self, d: int, status: int) -> str:
        if self.devices is None:
            return f"device {d} status {status}"
        return device_reason(self.devices[d], status)

    def _stale_cause(self, d: int) -> str:
        """`` (what the driver says about it)``, or nothing when it cannot tell."""
        ask = None if self.devices is None else getattr(self.devices[d], "stale_cause", None)
        try:
            cause = ask() if ask is not None else None
        except Exception as e:
            cause = f"its cause could not be read: {type(e).__name__}: {e}"
        return f" ({cause})" if cause else ""

    def _latch_nonfinite_command(self, command, where):
        fields = (command.tau_ff, command.q_des, command.qd_des, command.kp, command.kd)
        bad = ~np.isfinite(command.tau_ff)
        if int(command.mode) == k.IMPEDANCE:
            bad |= ~np.all(np.isfinite(fields), axis=0)
        j = int(np.flatnonzero(bad)[0])
        self._latch(FaultKind.NONFINITE_COMMAND, j, float(command.tau_ff[j]),
                    f"non-finite command for joint {j}{where}")

    def _latch(self, kind: FaultKind, joint: int, value: float, reason: str):
        slot = joint if joint >= 0 else self.n
        if self._latched[slot] & kind:
            return
        self._latched[slot] |= kind
        fault = Fault(kind, joint, self._tick, self._t, value, reason)
        self.faults.append(fault)
        if not self._faulted:
            self._faulted = True
            self._t_fault = self._t
            self._snapshot_hold()
        if kind & STOPPING and not self._stopping:
            self._stopping = True
            self._t_stop = self._t
        self._event("fault", "warning", **fault.as_dict())

    def _snapshot_hold(self):
        if self._state is None:
            return  # nothing measured yet: the fallback damps instead of holding
        q = self._state.position
        self.fb[k.Q_HOLD] = q
        if self.gravity is not None and np.all(np.isfinite(q)):
            try:
                self.fb[k.TAU_HOLD] = self.gravity(q.copy())
            except Exception as e:  # hold without it rather than not at all
                self._event("gravity_failed", "warning", reason=f"{type(e).__name__}: {e}")

    def _cause_gone(self, f: Fault) -> bool:
        st, j = self._state, f.joint
        if st is None or j < 0:
            return True  # e-stop, controller, guard: acknowledged by the reset itself
        q, qd, lim = st.position[j], st.velocity[j], self.lim
        if f.kind == FaultKind.POSITION:
            return bool(lim[k.HARD_LO, j] <= q <= lim[k.HARD_HI, j])
        if f.kind == FaultKind.VELOCITY:
            return bool(abs(qd) <= lim[k.V_LIM, j])
        if f.kind == FaultKind.NONFINITE_STATE:
            return bool(np.isfinite(q) and np.isfinite(qd))
        if f.kind == FaultKind.STALE:
            return bool(self.iw[k.STALE_COUNT, j] == 0)
        if f.kind & _DEVICE_KINDS:
            return bool(self._statuses[self.device_of_joint[j]] == 0)
        return True  # non-finite command, following error: the loop resets the controllers and the reference

    def _event(self, name: str, level: str, **fields):
        event = {"event": name, "t": self._t, "tick": self._tick, **fields}
        if len(self.events) < _MAX_EVENTS:
            self.events.append(event)
        else:
            self.events_dropped += 1
        if self.log_events:
            getattr(log, level)(name, **{a: b for a, b in event.items() if a != "event"})
        if self.on_event is not None:
            try:
                self.on_event(event)
            except Exception as e:
                log.error("on_event_failed", error=f"{type(e).__name__}: {e}")
