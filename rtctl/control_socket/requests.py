"""The control-socket commands and the validation of their shape (not of their meaning).

=========  ====================================================================================
``cmd``    fields
=========  ====================================================================================
status     —
stop       — (controlled stop, then the daemon exits)
estop      —
reset      — (clear latched faults)
move       exactly one of ``q``: [n numbers] (target joint positions) or ``waypoints``:
           [[n numbers], ...]; optional ``duration``: number > 0 (with ``q``), ``times``:
           [numbers > 0, strictly increasing, one per waypoint] (with ``waypoints``; seconds
           from the start of the move at which each waypoint is reached: honoured exactly, or
           the move is refused with the limit it breaks), ``deg``: bool (positions in
           degrees; default false)
controllers —      (each configured controller: type, joints, rate, active or not, its tunable parameters)
switch     ``activate``, ``deactivate``: [controller names] (not both empty; ``deactivate`` absent:
           the active controllers of the joints the activated ones take over);
           optional ``estimates``: "initial" (default: the controllers that start begin from their
           configured estimates) or "keep" (an adaptive controller keeps what it had learnt)
get        ``key``: "NAME.KEY" (a controller's or ``safety``'s parameter)
set        ``key``: "NAME.KEY", ``value``: a number or a list of numbers (as in the configuration)
lease      ``zone``: a shared zone's name, ``seq``: the grant's number (int ≥ 1), ``expires_ns``: the
           holder's expiry on CLOCK_MONOTONIC (int > 0), or 0 to drop the lease (a cell's bridge
           sends it: docs/cell.md)
=========  ====================================================================================

:func:`validate` turns a decoded request into the dict the daemon's handler receives:
``{"cmd": ...}`` plus, for ``move``, ``q`` or ``waypoints`` as float64 arrays ((n,) or (m, n)),
``duration`` and ``times`` (float / float64 array, or None) and ``deg`` (bool). Whether the
target is reachable, within limits or sensible now is the handler's call.
"""
from __future__ import annotations

import math
from numbers import Real

import numpy as np

MAX_REQUEST_BYTES = 64 * 1024
MAX_MOVE_S = 1e6  # the trajectory planner's longest segment (rtctl.trajectory.planning.MAX_DURATION_S)

COMMANDS = {
    "status": frozenset(),
    "stop": frozenset(),
    "estop": frozenset(),
    "reset": frozenset(),
    "move": frozenset({"q", "waypoints", "duration", "times", "deg"}),
    "controllers": frozenset(),
    "switch": frozenset({"activate", "deactivate", "estimates"}),
    "get": frozenset({"key"}),
    "set": frozenset({"key", "value"}),
    "lease": frozenset({"zone", "seq", "expires_ns"}),
}
ESTIMATES = ("initial", "keep")
MAX_NAME = 200


class InvalidRequest(ValueError):
    """The request's shape is wrong; the message is sent back to the client as is."""


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise InvalidRequest(f"{where}: expected a finite number, got {value!r}")
    return float(value)


def _vector(value, where: str, n_joints: int | None) -> np.ndarray:
    if not isinstance(value, list) or not value:
        raise InvalidRequest(f"{where}: expected a non-empty list of numbers, got {type(value).__name__}")
    if n_joints is not None and len(value) != n_joints:
        raise InvalidRequest(f"{where}: expected {n_joints} joint positions, got {len(value)}")
    # at C speed (the loop's thread validates: a 64 KiB request is 7000 numbers); the element
    # at fault is looked for only when something is wrong
    if set(map(type, value)) <= {int, float}:
        try:
            out = np.array(value, dtype=float)
        except OverflowError:
            out = None
        if out is not None and np.isfinite(out).all():
            return out
    return np.array([_number(v, f"{where}[{i}]") for i, v in enumerate(value)])


def _move(request: dict, n_joints: int | None) -> dict:
    has_q, has_wp = "q" in request, "waypoints" in request
    if has_q == has_wp:
        raise InvalidRequest("move: give exactly one of 'q' (target positions) or 'waypoints'")
    out = {"cmd": "move", "q": None, "waypoints": None, "duration": None, "times": None, "deg": False}
    if "deg" in request:
        if not isinstance(request["deg"], bool):
            raise InvalidRequest(f"move.deg: expected true or false, got {request['deg']!r}")
        out["deg"] = request["deg"]
    if has_q:
        if "times" in request:
            raise InvalidRequest("move.times: only with 'waypoints' (use 'duration' with 'q')")
        out["q"] = _vector(request["q"], "move.q", n_joints)
        if "duration" in request:
            out["duration"] = _number(request["duration"], "move.duration")
            if not 0 < out["duration"] <= MAX_MOVE_S:
                raise InvalidRequest(f"move.duration: expected > 0 s and ≤ {MAX_MOVE_S:g} s, got {out['duration']}")
        return out
    if "duration" in request:
        raise InvalidRequest("move.duration: only with 'q' (use 'times' with 'waypoints')")
    waypoints = request["waypoints"]
    if not isinstance(waypoints, list) or not waypoints:
        raise InvalidRequest("move.waypoints: expected a non-empty list of joint-position lists")
    rows = [_vector(w, f"move.waypoints[{i}]", n_joints) for i, w in enumerate(waypoints)]
    if len({len(r) for r in rows}) != 1:
        raise InvalidRequest("move.waypoints: every waypoint must have the same number of joints")
    out["waypoints"] = np.array(rows)
    if "times" in request:
        times = request["times"]
        if not isinstance(times, list) or len(times) != len(rows):
            raise InvalidRequest(f"move.times: expected a list of {len(rows)} numbers (one per waypoint)")
        out["times"] = np.array([_number(t, f"move.times[{i}]") for i, t in enumerate(times)])
        if out["times"][0] <= 0 or np.any(np.diff(out["times"]) <= 0) or out["times"][-1] > MAX_MOVE_S:
            raise InvalidRequest(f"move.times: expected seconds > 0, strictly increasing, ≤ {MAX_MOVE_S:g}")
    return out


def _names(request: dict, field: str) -> list[str] | None:
    if field not in request:
        return None
    names = request[field]
    if not isinstance(names, list) or not all(isinstance(x, str) and 0 < len(x) <= MAX_NAME for x in names):
        raise InvalidRequest(f"switch.{field}: expected a list of controller names")
    if len(set(names)) != len(names):
        raise InvalidRequest(f"switch.{field}: a controller named twice")
    return names


def _switch(request: dict) -> dict:
    out = {"cmd": "switch", "activate": _names(request, "activate") or [],
           "deactivate": _names(request, "deactivate"), "estimates": request.get("estimates", "initial")}
    if not out["activate"] and not out["deactivate"]:
        raise InvalidRequest("switch: name controllers to activate and/or deactivate")
    if out["estimates"] not in ESTIMATES:
        raise InvalidRequest(f"switch.estimates: expected one of {', '.join(ESTIMATES)}, got {out['estimates']!r}")
    return out


def _parameter(request: dict) -> dict:
    key = request.get("key")
    if not isinstance(key, str) or "." not in key or len(key) > MAX_NAME:
        raise InvalidRequest(f"{request['cmd']}.key: expected \"NAME.KEY\" (e.g. ct.kp), got {key!r}")
    out = {"cmd": request["cmd"], "key": key}
    if request["cmd"] == "set":
        if "value" not in request:
            raise InvalidRequest("set.value: missing; expected a number or a list of numbers")
        out["value"] = request["value"]  # checked by the parameter's own reader, as in the config file
    return out


def _lease(request: dict) -> dict:
    zone = request.get("zone")
    if not isinstance(zone, str) or not 0 < len(zone) <= MAX_NAME:
        raise InvalidRequest(f"lease.zone: expected a zone name, got {zone!r}")
    out = {"cmd": "lease", "zone": zone}
    for field, least in (("seq", 1), ("expires_ns", 0)):
        value = request.get(field)
        if isinstance(value, bool) or not isinstance(value, int) or not least <= value < 2 ** 63:
            raise InvalidRequest(f"lease.{field}: expected an integer >= {least}, got {value!r}")
        out[field] = value
    return out


def validate(request, n_joints: int | None = None) -> dict:
    """The handler's view of ``request``, or :class:`InvalidRequest` saying what is wrong."""
    if not isinstance(request, dict):
        raise InvalidRequest(f"expected a map with a 'cmd' key, got {type(request).__name__}")
    cmd = request.get("cmd")
    if not isinstance(cmd, str) or cmd not in COMMANDS:
        raise InvalidRequest(f"unknown cmd {cmd!r}; expected one of: {', '.join(COMMANDS)}")
    unknown = set(request) - COMMANDS[cmd] - {"cmd"}
    if unknown:
        allowed = ", ".join(sorted(COMMANDS[cmd])) or "none"
        raise InvalidRequest(f"{cmd}: unknown field(s) {', '.join(sorted(map(str, unknown)))}; allowed: {allowed}")
    if cmd == "move":
        return _move(request, n_joints)
    if cmd == "switch":
        return _switch(request)
    if cmd in ("get", "set"):
        return _parameter(request)
    if cmd == "lease":
        return _lease(request)
    return {"cmd": cmd}
