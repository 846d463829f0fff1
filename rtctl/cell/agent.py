"""A robot's lease agent, in its bridge (docs/cell.md, "Shared zones").

Each state period the bridge reads the daemon's ``status``; for each shared zone it reports
whether the robot *wants* it (inside it, or its path ahead enters it) and whether it holds a
lease. The agent then, one request at a time (a reply that comes after its timeout is
discarded by Zenoh, so no grant is ever applied out of order):

* wanted, and not held or due for renewal (the daemon says when) → ``acquire`` at the arbiter; the robot's expiry is
  counted from the moment the request was *sent*: t_send + d; a grant that arrives after that
  is dropped; else it goes to the daemon (``lease`` on the control socket), which checks it
  again against its own clock;
* not wanted while a grant is outstanding → ``lease`` with ``expires_ns`` 0 to the daemon
  first (refused while the robot is inside or about to enter; grants up to that number are
  refused from then on), then ``release`` at the arbiter with the number of the last grant.
"""
from __future__ import annotations

import json
import time

from rtctl.cell.config import ARBITER
from rtctl.cell.lease import holder_expiry_ns
from rtctl.control_socket.client import request
from rtctl.errors import ControlSocketError

RETRY_S = 0.05  # after a refusal, before asking again


class LeaseAgent:
    def __init__(self, cell, robot, socket_path, session, say=print):
        self.cell, self.robot, self.socket, self.session, self.say = cell, robot, socket_path, session, say
        self.key = cell.key(ARBITER, "cmd", "lease")
        self.timeout_s = min(0.25 * cell.lease_s, 0.5)
        self.last_seq: dict = {}  # zone: the last grant received
        self.owed: dict = {}  # zone: a grant not yet released at the arbiter
        self.next_try: dict = {}
        self.refusals = 0

    def step(self, status: dict) -> None:
        zones = status.get("zones")
        if not isinstance(zones, dict):
            return
        now = time.monotonic()
        for zone, info in zones.items():
            if not isinstance(info, dict) or now < self.next_try.get(zone, 0.0):
                continue
            wanted, held, renew = (info.get(k) is True for k in ("wanted", "held", "renew"))
            if wanted and (not held or renew):
                if not self._acquire(zone):
                    self.next_try[zone] = now + RETRY_S
            elif not wanted and zone in self.owed:
                self._release(zone)

    def _ask(self, op: str, zone: str, seq: int = 0) -> dict | None:
        payload = json.dumps({"op": op, "zone": zone, "robot": self.robot.name, "seq": seq})
        for reply in self.session.get(self.key, payload=payload, timeout=self.timeout_s):
            if reply.ok is None:
                continue
            try:
                answer = json.loads(reply.ok.payload.to_bytes())
            except ValueError:
                return None
            if isinstance(answer, dict) and isinstance(answer.get("granted"), bool) \
                    and isinstance(answer.get("seq"), int) and isinstance(answer.get("duration_s"), (int, float)) \
                    and answer["duration_s"] > 0:
                return answer
            return None
        return None  # no arbiter within the timeout

    def _acquire(self, zone: str) -> bool:
        sent_ns = time.monotonic_ns()  # (before the request leaves: the holder's view expires first)
        answer = self._ask("acquire", zone)
        if answer is None or not answer["granted"]:
            self.refusals += 1
            return False
        seq = answer["seq"]
        self.last_seq[zone] = self.owed[zone] = seq
        expires_ns = holder_expiry_ns(sent_ns, min(answer["duration_s"], self.cell.lease_s))
        if time.monotonic_ns() >= expires_ns:
            return False
        try:
            reply = request(self.socket, "lease", zone=zone, seq=seq, expires_ns=expires_ns, timeout=self.timeout_s)
        except ControlSocketError:
            return False
        return bool(reply.get("ok"))

    def _release(self, zone: str) -> None:
        seq = self.owed[zone]
        try:
            reply = request(self.socket, "lease", zone=zone, seq=seq, expires_ns=0, timeout=self.timeout_s)
        except ControlSocketError:
            return
        if not reply.get("ok"):
            return  # inside, or about to enter: it keeps the lease
        answer = self._ask("release", zone, seq)
        if answer is not None:  # (granted, or a stale number: either way nothing more to release)
            del self.owed[zone]
