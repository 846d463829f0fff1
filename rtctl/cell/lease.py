"""Shared-zone leases: the arbiter's table (docs/cell.md, "Shared zones").

A single arbiter per cell (as a cell PLC is) owns every shared zone W. It grants a robot a
lease of duration ``d``; the robot's lease agent renews it while the robot needs W and
releases it once out. This module is the arbiter's bookkeeping, pure and clocked from outside
(the process around it, :mod:`rtctl.cell.arbiter`, passes CLOCK_MONOTONIC; the tests a fake
clock). The safety argument it implements:

* **The holder's view expires first.** The holder counts its lease from the moment it *sent*
  the request (t_send + d); the arbiter from the moment it *granted* it, plus a margin m
  (grant + d + m). Causality puts t_send before the grant, so whatever the delay, the holder
  stops counting on a lease before the arbiter stops counting it as held (m covers the two
  clocks' rate difference and the loop's last tick).
* **An expired lease is not a free zone.** When the arbiter's view of R's lease expires without
  a release, R may have been stopped inside W (its guard stops it there). W stays R's —
  *unconfirmed* — until R says it is outside and holds nothing, in a reply to a status query
  the arbiter sent *after* the expiry (so the reply describes R after every lease it was ever
  granted had expired at R), or until R releases with the sequence number of its last grant,
  or until R itself asks again (it is then the holder). A robot that does not answer — its
  daemon killed, its link cut — keeps W. A peer whose lease may still be valid counts as inside.
* **A release names its grant.** ``release(R, seq)`` frees W only when ``seq`` is the last grant
  the arbiter gave R; a release delayed past a later grant is ignored. The agent releases only
  after its daemon has dropped the lease (and refuses every grant up to ``seq`` from then on)
  and reported itself outside W.
* **A restarted arbiter knows nothing**: it treats every robot of every zone as unconfirmed
  from its start + d + m (a lease the previous arbiter granted has expired by then), and grants
  nothing before.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class ZoneState:
    robots: tuple  # the robots that can reach the zone
    holder: str | None = None
    until: float = -math.inf  # arbiter time at which the holder's lease stops counting (grant + d + m)
    seq: int = 0  # the last grant's number
    last_seq: dict = field(default_factory=dict)  # robot: the last grant it was given
    unconfirmed: dict = field(default_factory=dict)  # robot: arbiter time after which its report counts


@dataclass(frozen=True)
class Answer:
    granted: bool
    seq: int = 0
    reason: str = ""


class LeaseTable:
    """Every shared zone's holder. ``zones``: {zone name: the robots that reach it};
    ``duration_s`` d and ``margin_s`` m as above; ``now``: the arbiter's start time."""

    def __init__(self, zones: dict, duration_s: float, margin_s: float, now: float):
        if not isinstance(zones, dict) or not zones or not all(
                isinstance(r, (tuple, list)) and len(r) >= 2 for r in zones.values()):
            raise ValueError("zones: expected {zone: (at least two robots)}")
        if not (math.isfinite(duration_s) and duration_s > 0 and math.isfinite(margin_s) and margin_s >= 0):
            raise ValueError(f"need a lease duration > 0 and a margin >= 0, got {duration_s!r}, {margin_s!r}")
        self.d, self.m = float(duration_s), float(margin_s)
        self.quiet_until = now + self.d + self.m
        self.zones = {z: ZoneState(tuple(r), unconfirmed={x: self.quiet_until for x in r}) for z, r in zones.items()}
        self._seq = 0

    def _zone(self, zone: str, robot: str) -> ZoneState:
        z = self.zones.get(zone)
        if z is None:
            raise ValueError(f"no shared zone {zone!r}")
        if robot not in z.robots:
            raise ValueError(f"robot {robot!r} has no region in zone {zone!r}")
        return z

    def _expire(self, z: ZoneState, now: float) -> None:
        if z.holder is not None and now >= z.until:
            z.unconfirmed[z.holder] = z.until  # (may be stopped inside W: counts as inside until it says not)
            z.holder = None

    def acquire(self, zone: str, robot: str, now: float) -> Answer:
        """A request or a renewal from ``robot``: a grant of ``d`` from now, or why not."""
        z = self._zone(zone, robot)
        self._expire(z, now)
        if z.holder is not None and z.holder != robot:
            return Answer(False, reason=f"held by {z.holder}")
        if now < self.quiet_until:
            return Answer(False, reason="the arbiter has just started: leases it may have granted before are "
                                        "still running")
        others = sorted(r for r in z.unconfirmed if r != robot)
        if others:
            return Answer(False, reason=f"waiting for {', '.join(others)} to report itself outside")
        self._seq += 1
        z.holder, z.until, z.seq = robot, now + self.d + self.m, self._seq
        z.last_seq[robot] = self._seq
        z.unconfirmed.pop(robot, None)  # (the holder's lease covers it)
        return Answer(True, self._seq)

    def release(self, zone: str, robot: str, seq: int, now: float) -> Answer:
        """``robot`` has dropped its grant ``seq`` and is outside: W is free of it (a stale
        ``seq`` changes nothing)."""
        z = self._zone(zone, robot)
        self._expire(z, now)
        if seq != z.last_seq.get(robot):
            return Answer(False, reason=f"not its last grant ({z.last_seq.get(robot)})")
        if z.holder == robot:
            z.holder = None
        z.unconfirmed.pop(robot, None)
        return Answer(True, seq)

    def to_confirm(self, now: float) -> list:
        """[(zone, robot)] whose report the arbiter should ask for now."""
        out = []
        for name, z in self.zones.items():
            self._expire(z, now)
            out += [(name, r) for r, since in z.unconfirmed.items() if now >= since]
        return out

    def confirm(self, zone: str, robot: str, asked_at: float, held: bool, inside: bool) -> bool:
        """``robot``'s reply to a status query sent at ``asked_at``: it is outside W and holds no
        lease (True: it no longer keeps W). A reply to a query sent before the lease expired
        (or before the arbiter's quiet period ended) proves nothing."""
        z = self._zone(zone, robot)
        since = z.unconfirmed.get(robot)
        if since is None or asked_at < since or held or inside or z.holder == robot:
            return False
        del z.unconfirmed[robot]
        return True

    def view(self, now: float) -> dict:
        """{zone: {"holder", "expires_in", "unconfirmed"}} for status and telemetry."""
        out = {}
        for name, z in self.zones.items():
            self._expire(z, now)
            out[name] = {"holder": z.holder, "expires_in": None if z.holder is None else z.until - now,
                         "unconfirmed": sorted(z.unconfirmed)}
        return out


def holder_expiry_ns(sent_ns: int, duration_s: float) -> int:
    """The holder's own expiry: from when it *sent* the request, never when the grant arrived."""
    return int(sent_ns) + int(duration_s * 1e9)
