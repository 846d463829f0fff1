"""One robot's bridge between its daemon and the cell's Zenoh network (docs/cell.md).

``python -m rtctl.cell.bridge CONFIG-JSON`` (``{"cell": PATH, "robot": NAME, "socket": PATH}``),
started by ``rtctl cell up`` beside the daemon. Zenoh never runs in the loop's process: this
process talks to the daemon only through its control socket, the way ``rtctl status`` does.
It carries the e-stop, so it runs at the cell's ``bridge_priority`` (SCHED_FIFO 60 by default,
below the loops' 80): the machine's ordinary work cannot starve it, and the loops preempt it.

* ``rtctl/<cell>/<robot>/cmd/<name>`` — a queryable; ``status``, ``stop``, ``estop``,
  ``reset`` and ``move`` are forwarded to the control socket (a ``move``'s fields as the
  query's JSON payload) and the daemon's reply comes back as JSON;
* ``…/state`` — the daemon's state (q, q̇, verdict, e-stop, active faults, tick) at the
  cell's ``state_rate_hz`` (default 100 Hz), from a ``status`` request each period;
* ``…/events`` — a change of verdict, e-stop, faults or stopping, once, when first seen;
* ``…/status`` — the state plus where the robot is served from, at ``status_rate_hz``;
* the robot's shared-zone leases, asked of the cell's arbiter and handed to the daemon
  (:mod:`rtctl.cell.agent`), after each state.

It exits when SIGTERM/SIGINT arrives or its daemon is gone (the control socket refuses).
"""
from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time

from rtctl.cell.agent import LeaseAgent
from rtctl.cell.config import load_cell
from rtctl.cell.session import open_bridge_session, raise_priority
from rtctl.control_socket.client import request
from rtctl.errors import EXIT_SOCKET, ControlSocketError

FORWARDED = ("status", "stop", "estop", "reset", "move")
REQUEST_TIMEOUT_S = 2.0
GONE_AFTER = 3  # failed status requests in a row: the daemon is gone
WATCHED = ("verdict", "estopped", "faults", "stopping")


def forward(socket_path, name: str, payload: bytes | None) -> dict:
    """The daemon's reply to command ``name`` (with ``payload``'s JSON fields), or why there is none."""
    if name not in FORWARDED:
        return {"ok": False, "error": f"unknown command {name!r}; the cell forwards {', '.join(FORWARDED)}"}
    fields = {}
    if payload:
        try:
            fields = json.loads(payload)
        except ValueError as e:
            return {"ok": False, "error": f"{name}: the payload is not JSON ({e})"}
        if not isinstance(fields, dict):
            return {"ok": False, "error": f"{name}: expected a JSON object of fields, got {type(fields).__name__}"}
        fields.pop("cmd", None)
    try:
        return request(socket_path, name, timeout=REQUEST_TIMEOUT_S, **fields)
    except ControlSocketError as e:
        return {"ok": False, "error": str(e)}


class Bridge:
    def __init__(self, cell, robot, socket_path, session):
        self.cell, self.robot, self.socket = cell, robot, socket_path
        self.session = session
        key = lambda *p: cell.key(robot.name, *p)  # noqa: E731
        self.state = session.declare_publisher(key("state"))
        self.events = session.declare_publisher(key("events"))
        self.status = session.declare_publisher(key("status"))
        self.queryable = session.declare_queryable(key("cmd", "*"), self._on_query)
        self.previous: dict | None = None
        self.published = 0
        self.agent = LeaseAgent(cell, robot, socket_path, session)  # (a no-op for a robot without shared zones)

    def _on_query(self, query) -> None:
        """(A Zenoh thread.) The command is the key's last chunk; a reply is always sent."""
        received_ns = time.monotonic_ns()
        name = str(query.key_expr).rsplit("/", 1)[-1]  # (the robot chunk may be a wildcard: the whole cell)
        payload = query.payload.to_bytes() if query.payload is not None else None
        reply = forward(self.socket, name, payload) | {"robot": self.robot.name, "bridge_received_ns": received_ns}
        query.reply(self.cell.key(self.robot.name, "cmd", name), json.dumps(reply))

    def serve(self, stop: threading.Event) -> int:
        period = 1.0 / self.cell.state_rate_hz
        status_every = max(1, round(self.cell.state_rate_hz / self.cell.status_rate_hz))
        failures, k = 0, 0
        next_t = time.monotonic()
        while not stop.is_set():
            try:
                status = request(self.socket, "status", timeout=REQUEST_TIMEOUT_S)
                if not status["ok"]:  # (at its exit the daemon refuses it: "the daemon is stopping (…)")
                    raise ControlSocketError(status.get("error") or "status refused")
                failures = 0
            except ControlSocketError as e:
                failures += 1
                if failures >= GONE_AFTER:
                    self.events.put(json.dumps({"event": "daemon gone", "robot": self.robot.name, "error": str(e)}))
                    return 0
                status = None
            if status is not None:
                self._publish(status, k % status_every == 0)
                self.agent.step(status)
            k += 1
            next_t += period
            delay = next_t - time.monotonic()
            if delay < 0:  # fell behind (the machine is loaded): the rate drops, no burst to catch up
                next_t, delay = time.monotonic(), 0.0
            stop.wait(delay)
        return 0

    def _publish(self, status: dict, with_status: bool) -> None:
        status = status | {"robot": self.robot.name, "stamp_ns": time.monotonic_ns()}
        text = json.dumps(status)
        self.state.put(text)
        self.published += 1
        for name in WATCHED:
            if self.previous is not None and status.get(name) != self.previous.get(name):
                self.events.put(json.dumps({"event": f"{name} changed", "robot": self.robot.name, "t": status["t"],
                                            "tick": status["tick"], "from": self.previous.get(name),
                                            "to": status.get(name)}))
        self.previous = status
        if with_status:
            self.status.put(json.dumps({"daemon": status, "robot": self.robot.name, "bridge_pid": os.getpid(),
                                        "socket": str(self.socket),
                                        "endpoint": self.robot.endpoint(),
                                        "base": self.robot.base.tolist(), "state_rate_hz": self.cell.state_rate_hz,
                                        "state_messages": self.published}))


def main(argv=None) -> int:
    config = json.loads((argv or sys.argv[1:])[0])
    stop = threading.Event()
    for s in (signal.SIGTERM, signal.SIGINT):
        signal.signal(s, lambda *_: stop.set())
    cell = load_cell(config["cell"], check_robots=False)
    robot = cell.robot(config["robot"])
    unprioritised = raise_priority(cell)
    if unprioritised:
        print(f"rtctl bridge {robot.name}: {unprioritised}", file=sys.stderr)
    try:
        session = open_bridge_session(cell, robot)
    except Exception as e:  # zenoh.ZError: e.g. the port is taken
        print(f"rtctl bridge {robot.name}: cannot open its Zenoh session on {robot.endpoint()}: {e}", file=sys.stderr)
        return EXIT_SOCKET
    try:
        return Bridge(cell, robot, config["socket"], session).serve(stop)
    finally:
        session.close()


if __name__ == "__main__":
    sys.exit(main())
