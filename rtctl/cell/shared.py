"""A robot's shared zones, in its loop (docs/cell.md, "Shared zones"): leases, guard, gate.

``rtctl run … --cell CELLFILE --cell-robot NAME`` (what ``rtctl cell up`` starts) enforces the
cell's shared zones for that robot. No Zenoh here: a lease reaches the loop as a ``lease``
request on the daemon's control socket, from the robot's bridge, and is acted on at a tick
boundary. Per tick the loop compares numbers:

* **guard** — :class:`ZoneGuard` runs the robot's own guard, then, for every shared zone whose
  lease is not held (``t ≥ expiry``), the same compiled stopping-distance check
  (:class:`~rtctl.guard.runtime.RuntimeGuard`, action "stop") against the robot's region of
  that zone inflated by the guard margin: a robot that would enter W without its lease stops;
* **gate** — the running trajectory waits at the border of a zone it may not enter
  (:mod:`rtctl.cell.gate`).

``expiry`` is loop time: the holder's own expiry (from when its bridge *sent* the request,
CLOCK_MONOTONIC) placed on the loop's clock (tick k is due at tick0 + k·period), less two
periods for the tick that decides. The gate's ``gate_expiry`` is earlier by the horizon its
path needs to come to rest (:func:`stopping_horizon`), so that a path does not start into a
zone on a lease about to end.
"""
from __future__ import annotations

import time

import numpy as np

from rtctl.cell.gate import Gate, gate_parameters, gate_step, ring_rows
from rtctl.errors import ConfigError, RtctlError
from rtctl.guard import kernels as gk
from rtctl.guard.runtime import RuntimeGuard
from rtctl.guard.zones import Scene, Zone
from rtctl.safety.faults import GuardVerdict

DEFAULT_GATE_MARGIN = 0.05  # rad: a waiting reference rests at least half of it from the zone
DEFAULT_GUARD_MARGIN = 0.01  # rad


class SharedZones:
    """``zones``: [(name, part)] — this robot's region of each shared zone (rad/m)."""

    def __init__(self, zones, model, limits, dt: float, lease_s: float, *, gate_margin: float = DEFAULT_GATE_MARGIN,
                 guard_margin: float = DEFAULT_GUARD_MARGIN, deceleration=None, damping=5.0, stiffness=50.0):
        if not zones:
            raise ValueError("zones: expected at least one (name, part)")
        if not 0 <= guard_margin <= gate_margin / 2:
            raise ValueError(f"guard margin {guard_margin!r}: expected 0 … half the gate margin {gate_margin!r}")
        self.names = tuple(name for name, _ in zones)
        self.scene = Scene(tuple(Zone(name, (part,)) for name, part in zones), model.q_min, model.q_max,
                           joint_names=model.joint_names)
        self.rows, self.cols, self.pieces = self.scene.tables()
        decel = limits.a_max if deceleration is None else deceleration
        self.guards = [RuntimeGuard(Scene((z,), model.q_min, model.q_max, joint_names=model.joint_names), decel, dt,
                                    margin=guard_margin, action="stop", damping=damping, stiffness=stiffness)
                       for z in self.scene.zones]
        joints = sorted(set(self.cols.ravel().tolist()))
        self.gate_par = gate_parameters(limits.v_max, limits.a_max, gate_margin, dt, joints)
        self.accel = np.array(limits.a_max, float)
        self.decel = np.broadcast_to(np.asarray(decel, float), (model.nq,)).copy()
        self.clearance = gate_margin - 0.5 * float(np.linalg.norm(limits.v_max[joints])) * self.gate_par[1]
        if self.clearance <= guard_margin:
            raise ValueError(f"gate margin {gate_margin!r} too small for these speeds (the sampled look-ahead "
                             f"certifies only {self.clearance:.4g} rad, not more than the guard margin)")
        self.horizon = stopping_horizon(limits, dt, float(self.gate_par[1]))
        if not lease_s > 2 * self.horizon:
            raise LeaseTooShort(f"more than {2 * self.horizon:.2f} s (twice the {self.horizon:.2f} s this robot's "
                                f"path needs to come to rest), got {lease_s:g}")
        self.lease_s, self.dt = float(lease_s), float(dt)
        nz = len(self.names)
        self.expiry = np.full(nz, -np.inf)  # loop time; the guard lets the robot in while t < expiry
        self.gate_expiry = np.full(nz, -np.inf)  # the gate's: expiry − horizon
        self.entry, self.room = np.full(nz, np.inf), np.full(nz, np.inf)
        self.held, self.waiting = np.zeros(nz), np.zeros(nz)
        self.seq = [0] * nz  # the grant held (or last held)
        self.floor = [0] * nz  # grants up to this number are refused (dropped, or stale)
        self.tmp = np.zeros((4, model.nq))
        self.ring = np.zeros((ring_rows(self.gate_par), nz + 1))  # the gate's samples of the path ahead
        self.tick0_ns = 0  # CLOCK_MONOTONIC of tick 0 (set when the loop starts)
        self.guard_margin = guard_margin
        self.gate: Gate | None = None

    # -- the loop's hooks --------------------------------------------------------------
    def gated(self, trajectory, t: float) -> Gate:
        """The trajectory the tick samples: ``trajectory`` behind the gate, from loop time ``t``."""
        self.gate = Gate(trajectory, self, t)
        return self.gate

    def guard(self, own):
        return ZoneGuard(own, self)

    def warm_up(self) -> None:
        n = self.tmp.shape[1]
        from rtctl.trajectory import hold

        h = hold(np.zeros(n))
        q = np.zeros((3, n))
        st = Gate(h, self, 0.0).st
        gate_step(h.knots, h.coeffs, 0.0, self.gate_expiry.copy(), self.rows, self.cols, self.pieces, self.accel,
                  self.gate_par, st, self.ring.copy(), self.entry.copy(), self.room.copy(), self.held.copy(),
                  self.waiting.copy(), q[0], q[1], q[2], self.tmp.copy())
        for g in self.guards:
            g.warm_up()

    def telemetry_columns(self) -> dict:
        """Per shared zone, every tick: the gate holds the lease (1/0), waits for it (1/0), and
        how far ahead (trajectory time, s) its path enters the zone (inf: not within sight)."""
        return {"zones_held": self.held, "zones_waiting": self.waiting, "zones_entry": self.entry}

    # -- the control socket's ``lease`` --------------------------------------------------
    def lease(self, req: dict, t: float, q, qd) -> dict:
        """A grant (``expires_ns`` > 0: the holder's expiry on CLOCK_MONOTONIC, ``seq`` its
        number) or a drop (``expires_ns`` = 0: refused while the robot is inside the zone or its
        path wants it; grants up to ``seq`` are refused from then on)."""
        z = self._index(req["zone"])
        seq, expires_ns = req["seq"], req["expires_ns"]
        if expires_ns == 0:
            why = self._needs(z, q, qd)
            if why:
                return {"ok": False, "error": f"lease {self.names[z]!r} not dropped: {why}"}
            self.expiry[z] = self.gate_expiry[z] = -np.inf
            self.floor[z] = max(self.floor[z], seq)
            return {"ok": True, "zone": self.names[z], "held": False, "inside": False}
        if seq <= self.floor[z]:
            return {"ok": False, "error": f"lease {self.names[z]!r}: grant {seq} is stale (refused up to "
                                          f"{self.floor[z]})"}
        now_ns = time.monotonic_ns()
        if expires_ns <= now_ns:
            return {"ok": False, "error": f"lease {self.names[z]!r}: grant {seq} expired "
                                          f"{(now_ns - expires_ns) * 1e-6:.1f} ms before it arrived"}
        if expires_ns > now_ns + self.lease_s * 1e9:
            return {"ok": False, "error": f"lease {self.names[z]!r}: grant {seq} would run "
                                          f"{(expires_ns - now_ns) * 1e-9:.3f} s, longer than the cell's "
                                          f"{self.lease_s:g} s leases"}
        self.floor[z] = self.seq[z] = seq
        # (tick k starts at or after tick0 + k·period: two periods cover the tick that decides)
        self.expiry[z] = (expires_ns - self.tick0_ns) * 1e-9 - 2 * self.dt
        self.gate_expiry[z] = self.expiry[z] - self.horizon
        return {"ok": True, "zone": self.names[z], "held": bool(t < self.expiry[z]),
                "lease_s": float(self.expiry[z] - t), "gate_lease_s": float(self.gate_expiry[z] - t)}

    def status(self, t: float, q, qd) -> dict:
        """{zone: held, lease_s, renew (half of what the gate may use of it is gone), wanted,
        waiting, inside (or stopping into it), seq}."""
        out = {}
        for z, name in enumerate(self.names):
            held = bool(t < self.expiry[z])
            out[name] = {"held": held, "lease_s": float(self.expiry[z] - t) if held else 0.0,
                         "renew": bool(self.gate_expiry[z] - t < 0.5 * (self.lease_s - self.horizon)),
                         "wanted": bool(self._needs(z, q, qd)), "waiting": bool(self.waiting[z]),
                         "inside": self.inside(z, q, qd), "seq": self.seq[z]}
        return out

    def gate_status(self) -> dict | None:
        g = self.gate
        return None if g is None else {"rate": g.rate, "t_path": g.tau, "finished": bool(g.finished)}

    def inside(self, z: int, q, qd) -> bool:
        """The robot's stopping path (as the guard predicts it: one period, then braking within
        the deceleration limits) meets the zone inflated by the guard margin — inside, or
        braking into it: what it reports to the arbiter errs on the side of inside."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        stop = q + qd * (self.dt + 0.5 * float(np.max(np.abs(qd) / self.decel)))
        p = self.pieces
        return any(gk.piece_entry(self.rows, self.cols, p[k, 0], p[k, 1], q, stop, self.guard_margin)[0] < gk.NO_ENTRY
                   for k in range(p.shape[0]) if p[k, 2] == z)

    def _needs(self, z: int, q, qd) -> str:
        if self.inside(z, q, qd):
            return "the robot is inside it (or its stopping path enters it)"
        if self.entry[z] != np.inf:
            return "the path ahead enters it"
        return ""

    def _index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise RtctlError(f"no shared zone {name!r} here (this robot's: {', '.join(self.names)})") from None


class LeaseTooShort(ValueError):
    """The cell's lease is too short for this robot's path to stop within it."""


def stopping_horizon(limits, dt: float, step: float) -> float:
    """How long before a lease's end the gate counts it gone: the time its reference needs to
    come to rest from full speed — the rate falls at b ≥ aⱼ/(2·(vⱼ + aⱼ·Δτ)) per second
    (gate.py), so within maxⱼ 2·vⱼ/aⱼ + 2·Δτ — plus three periods."""
    return 2.0 * float(np.max(limits.v_max / limits.a_max)) + 2 * step + 3 * dt


class ZoneGuard:
    """The safety stage's guard: the robot's own (may be None), then each shared zone whose
    lease is not held (the stopping-distance check, action "stop")."""

    def __init__(self, own, zones: SharedZones):
        self.own, self.zones = own, zones
        self.reason, self.event_due = "", False
        self._last = None

    def check(self, t: float, state, command) -> int:
        verdict = GuardVerdict.PASS
        self._last = None
        if self.own is not None:
            verdict = self.own.check(t, state, command)
            if verdict != GuardVerdict.PASS:
                self._last = self.own
            if verdict == GuardVerdict.STOP:
                return self._report(verdict)
        expiry = self.zones.expiry
        for z, g in enumerate(self.zones.guards):
            if t < expiry[z]:
                continue
            v = g.check(t, state, command)
            if v == GuardVerdict.STOP:
                self._last = g
                return self._report(v)
        return self._report(verdict)

    def _report(self, verdict) -> int:
        g = self._last
        self.event_due = g is not None and g.event_due
        if g is not None:
            self.reason = g.reason if g is self.own else g.reason + " (a shared zone whose lease is not held)"
        return verdict

    def event(self) -> dict:
        return self._last.event() if self._last is not None else {}

    def warm_up(self) -> None:
        if self.own is not None:
            self.own.warm_up()
        self.zones.warm_up()


def for_run(args, cfg, limits):
    """The run's shared zones (None unless ``--cell``): the cell file's regions for
    ``--cell-robot``, with the robot's guard margins when it has a guard (ConfigError: exit 2)."""
    path = getattr(args, "cell", None)
    if path is None:
        return None
    from rtctl.cell.config import load_cell

    robot = getattr(args, "cell_robot", None)
    cell = load_cell(path)
    if robot not in [r.name for r in cell.robots]:
        raise ConfigError("<command line>", "--cell-robot", f"a robot of cell {cell.name!r}, got {robot!r}")
    zones = [(z.name, r.part) for z in cell.zones for r in z.regions if r.robot == robot]
    if not zones:
        return None
    if cfg.loop.realtime_factor != 1.0:
        raise ConfigError(cfg.file, "loop.realtime_factor", "1 for a robot of a cell with shared zones "
                                                            "(leases run on the wall clock)")
    g = cfg.guard
    margins = {} if g is None else {"gate_margin": g.scene.margin or DEFAULT_GATE_MARGIN,
                                    "guard_margin": min(g.guard_margin, (g.scene.margin or DEFAULT_GATE_MARGIN) / 2),
                                    "deceleration": g.deceleration}
    try:
        return SharedZones(zones, cfg.model, limits, cfg.loop.period, cell.lease_s, damping=cfg.safety.damping,
                           stiffness=cfg.safety.hold_stiffness, **margins)
    except LeaseTooShort as e:
        raise ConfigError(path, "leases.duration_s", f"{e} for robot {robot!r}") from None
    except ValueError as e:
        raise ConfigError(path, "zones", str(e)) from None

