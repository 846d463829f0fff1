"""Run-time changes to a running daemon: list and switch controllers, get and set parameters
(``rtctl controllers|switch|get|set``; docs/operations.md, "Live operation").

Every request is handled in the loop's thread between two ticks (:mod:`rtctl.operator`), so a
change takes effect at one tick boundary, whole: a switch is checked entirely before any
controller changes, a value is checked by the configuration's own reader before it is written.
Each change is logged, kept as an event for the run's summary (and the MCAP export's log), and
recorded in telemetry every tick: the columns ``controllers_active`` (1 per active controller,
in the configuration's order) and ``NAME.KEY`` for every tunable parameter.
"""
from __future__ import annotations

import numpy as np
import structlog

from rtctl.control.tunable import read_value
from rtctl.errors import RtctlError
from rtctl.switching import plan_switch

log = structlog.get_logger("rtctl.daemon")

FIXED = {  # what a run cannot change without a restart, and why
    "robot": "the robot model is fixed for the run: restart with a new configuration",
    "devices": "the device layout is fixed for the run: restart with a new configuration",
    "loop": "the loop's rate and timing are fixed for the run: restart with a new configuration",
    "sim": "the simulator's settings are fixed for the run: restart with a new configuration",
    "telemetry": "the telemetry's layout is fixed for the run: restart with a new configuration",
}
ESTIMATES = ("initial", "keep")


class LiveChanges:
    """The daemon ``d``'s controllers and tunable parameters, as the socket's commands see them."""

    def __init__(self, daemon):
        self.d = daemon
        rt = daemon.rt
        self.configured = rt.configured
        self.active_flags = np.array([c in rt.controllers for c in self.configured], dtype=np.int8)
        self.tunables = {}  # "owner.key" → (owner, key, Tunable)
        for owner, name in [(c, c.name) for c in self.configured] + [(daemon.safety, "safety")]:
            for key, tunable in owner.tunables().items():
                self.tunables[f"{name}.{key}"] = (name, key, tunable)
        self.events: list[dict] = []

    def telemetry_columns(self) -> dict:
        """Column name → the array recorded every tick."""
        return {"controllers_active": self.active_flags,
                **{path: tunable.value for path, (_, _, tunable) in self.tunables.items()}}

    def controllers(self) -> dict:
        rate = self.d.cfg.loop.rate_hz
        names = self.d.model.joint_names
        return {"ok": True, "controllers": [
            {"name": c.name, "type": conf.type, "joints": [names[j] for j in c.joints], "rate_hz": rate / c.divisor,
             "state": "active" if flag else "inactive", "parameters": sorted(k for (o, k, _) in self.tunables.values()
                                                                             if o == c.name)}
            for c, conf, flag in zip(self.configured, self.d.cfg.controllers, self.active_flags)]}

    def switch(self, req: dict) -> dict:
        d = self.d
        rt = d.rt
        if d.estopped or d.safety.faulted:
            raise RtctlError("switch refused: faults are latched: `rtctl reset` first")
        deactivate = req["deactivate"]
        if deactivate is None:  # those whose joints the activated controllers take over
            taken = {int(j) for c in self.configured if c.name in req["activate"] for j in c.joints}
            deactivate = [c.name for c in rt.controllers
                          if c.name not in req["activate"] and taken & set(map(int, c.joints))]
        after = plan_switch(self.configured, rt.controllers, req["activate"], deactivate)
        started = [c for c in after if c not in rt.controllers]
        stopped = [c.name for c in rt.controllers if c not in after]
        for c in started:  # from the current state and reference (the run's, unchanged)
            (c.resume if req["estimates"] == "keep" else c.reset)(rt.state)
        d.tick.switch(after, started)
        self.active_flags[:] = [c in after for c in self.configured]
        return self._event("switch", started=[c.name for c in started], stopped=stopped,
                           estimates=req["estimates"], active=[c.name for c in after])

    def get(self, req: dict) -> dict:
        try:
            owner, key, tunable = self._find(req["key"])
        except RtctlError as e:
            return {"ok": False, "error": str(e), "invalid": True}
        return {"ok": True, "key": req["key"], "value": tunable.value.tolist()}

    def set(self, req: dict) -> dict:
        """Refused (``invalid``: the CLI exits 2) unless the key is tunable and the value passes the
        configuration's own checks for it; applied whole, at this tick boundary."""
        try:
            owner, key, tunable = self._find(req["key"])
            new = read_value(tunable, owner, key, req["value"])
        except RtctlError as e:  # (ConfigError included: names the key and what was expected)
            return {"ok": False, "error": str(e), "invalid": True}
        old = tunable.value.tolist()
        tunable.set(new)
        return self._event("set", key=req["key"], old=old, new=tunable.value.tolist())

    def _find(self, path: str):
        if path in self.tunables:
            return self.tunables[path]
        head, _, key = path.partition(".")
        if head in FIXED:
            raise RtctlError(f"{path}: cannot change at run time: {FIXED[head]}")
        owners = {c.name for c in self.configured} | {"safety"}
        if head not in owners:
            raise RtctlError(f"{path}: no controller {head!r} (controllers: {', '.join(c.name for c in self.configured)}; "
                             f"or 'safety')")
        here = sorted(k for (o, k, _) in self.tunables.values() if o == head)
        raise RtctlError(f"{path}: not a parameter {head!r} can change at run time (those it can: "
                         f"{', '.join(here) or 'none'}; the rest of its configuration needs a restart)")

    def _event(self, kind: str, **fields) -> dict:
        d = self.d
        event = {"event": kind, "t": d.ticker.sim_time_s, "tick": d.ticker.tick, **fields}
        self.events.append(event)
        log.info(kind, **{k: v for k, v in event.items() if k != "event"})
        return {"ok": True, **{k: v for k, v in event.items() if k != "event"}}
