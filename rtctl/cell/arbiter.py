"""The cell's shared-zone arbiter (docs/cell.md, "Shared zones"): one process, like a cell PLC.

``python -m rtctl.cell.arbiter CONFIG-JSON`` (``{"cell": PATH}``), started by ``rtctl cell up``
once every bridge runs. It holds the :class:`~rtctl.cell.lease.LeaseTable` and

* answers ``rtctl/<cell>/arbiter/cmd/lease`` — a queryable; the payload is JSON
  ``{"op": "acquire"|"release", "zone", "robot", "seq"}`` from a robot's lease agent
  (:mod:`rtctl.cell.agent`), the reply ``{"granted", "seq", "duration_s", "reason"}``;
* asks a robot whose lease expired without a release (or any robot, after its own start) for
  its status, through that robot's bridge (``…/<robot>/cmd/status``), until the robot reports
  itself outside the zone and holding nothing — the query is sent after the expiry, so the
  reply proves it;
* publishes its view on ``rtctl/<cell>/arbiter/state`` and logs every decision as a JSON line
  with its CLOCK_MONOTONIC stamp (the fault tests read it).

Its session is the cell's: peer mode, multicast scouting off, authenticated with the cell's
user; it connects to every bridge's endpoint (or to the router) and listens nowhere, so its
only links are those it opens to the cell's bridges, each of which checks its credentials and
applies the cell's access control to it.
"""
from __future__ import annotations

import json
import signal
import sys
import threading
import time

from rtctl.cell.config import ARBITER, NAME, load_cell
from rtctl.cell.lease import LeaseTable
from rtctl.cell.session import raise_priority, session_config, zenoh_module

CONFIRM_EVERY_S = 0.05
QUERY_TIMEOUT_S = 0.5


def parse_request(payload: bytes | None) -> dict:
    """The lease request's fields, validated (ValueError says what is wrong)."""
    try:
        req = json.loads(payload or b"")
    except ValueError as e:
        raise ValueError(f"the payload is not JSON ({e})") from None
    if not isinstance(req, dict) or set(req) - {"op", "zone", "robot", "seq"}:
        raise ValueError("expected {\"op\", \"zone\", \"robot\", \"seq\"}")
    if req.get("op") not in ("acquire", "release"):
        raise ValueError(f"op: expected \"acquire\" or \"release\", got {req.get('op')!r}")
    for key in ("zone", "robot"):
        if not isinstance(req.get(key), str) or not NAME.fullmatch(req[key]):
            raise ValueError(f"{key}: expected a name, got {req.get(key)!r}")
    seq = req.get("seq", 0)
    if isinstance(seq, bool) or not isinstance(seq, int) or seq < 0:
        raise ValueError(f"seq: expected an integer >= 0, got {seq!r}")
    return {"op": req["op"], "zone": req["zone"], "robot": req["robot"], "seq": seq}


class Arbiter:
    def __init__(self, cell, session, now=time.monotonic, say=print):
        self.cell, self.session, self.now, self.say = cell, session, now, say
        zones = {z.name: tuple(r.robot for r in z.regions) for z in cell.zones}
        self.table = LeaseTable(zones, cell.lease_s, cell.lease_margin_s, now())
        self.lock = threading.Lock()
        self.state = session.declare_publisher(cell.key(ARBITER, "state"))
        self.queryable = session.declare_queryable(cell.key(ARBITER, "cmd", "lease"), self._on_query)
        self._log("started", zones=zones, lease_s=cell.lease_s, margin_s=cell.lease_margin_s,
                  quiet_until=self.table.quiet_until)

    def _log(self, event: str, **fields) -> None:
        self.say(json.dumps({"event": event, "t_ns": time.monotonic_ns(), **fields}), flush=True)

    def _on_query(self, query) -> None:
        """(A Zenoh thread.) Always answers."""
        try:
            req = parse_request(query.payload.to_bytes() if query.payload is not None else None)
            with self.lock:
                now = self.now()
                if req["op"] == "acquire":
                    answer = self.table.acquire(req["zone"], req["robot"], now)
                else:
                    answer = self.table.release(req["zone"], req["robot"], req["seq"], now)
            if answer.granted:
                self._log("granted" if req["op"] == "acquire" else "released", zone=req["zone"],
                          robot=req["robot"], seq=answer.seq)
            reply = {"granted": answer.granted, "seq": answer.seq, "duration_s": self.cell.lease_s,
                     "reason": answer.reason}
        except ValueError as e:
            reply = {"granted": False, "seq": 0, "duration_s": self.cell.lease_s, "reason": str(e)}
        query.reply(self.cell.key(ARBITER, "cmd", "lease"), json.dumps(reply))

    def confirm_round(self) -> None:
        """Ask each unconfirmed robot for its status (one query each, sent now)."""
        zenoh = zenoh_module()
        with self.lock:
            pending = self.table.to_confirm(self.now())
        for zone, robot in pending:
            asked = self.now()
            reply = None
            for r in self.session.get(self.cell.key(robot, "cmd", "status"), target=zenoh.QueryTarget.ALL,
                                      timeout=QUERY_TIMEOUT_S):
                if r.ok is not None:
                    try:
                        reply = json.loads(r.ok.payload.to_bytes())
                    except ValueError:
                        reply = None
            info = (reply or {}).get("zones", {}).get(zone) if isinstance(reply, dict) else None
            if not isinstance(info, dict) or not reply.get("ok"):
                continue  # no answer, a daemon without the zone, or garbled: it keeps the zone
            with self.lock:
                done = self.table.confirm(zone, robot, asked, info.get("held") is not False,
                                          info.get("inside") is not False)
            if done:
                self._log("confirmed outside", zone=zone, robot=robot)

    def serve(self, stop: threading.Event) -> int:
        while not stop.is_set():
            self.confirm_round()
            with self.lock:
                view = self.table.view(self.now())
            self.state.put(json.dumps({"t_ns": time.monotonic_ns(), "zones": view}))
            stop.wait(CONFIRM_EVERY_S)
        return 0


def main(argv=None) -> int:
    config = json.loads((argv or sys.argv[1:])[0])
    stop = threading.Event()
    for s in (signal.SIGTERM, signal.SIGINT):
        signal.signal(s, lambda *_: stop.set())
    cell = load_cell(config["cell"])
    unprioritised = raise_priority(cell)
    if unprioritised:
        print(f"rtctl arbiter: {unprioritised}", file=sys.stderr)
    routed = bool(cell.zenoh.connect)
    zenoh = zenoh_module()
    session = zenoh.open(session_config(cell, connect=() if routed else tuple(r.endpoint() for r in cell.robots),
                                        user=cell.auth.user, password=cell.auth.password()))
    try:
        return Arbiter(cell, session).serve(stop)
    finally:
        session.close()


if __name__ == "__main__":
    sys.exit(main())
