"""Two PUMAs whose jobs cross one shared zone, and the checks made on their telemetry files.

Each robot's job (a ``move`` sent to both at once) swings its waist through its region of the
zone W and back. Whether a robot is inside W is computed here from the recorded q and the
region's box, independently of the daemon's flags."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from cell_helpers import free_port, write_cell
from rtctl.control_socket.client import request
from rtctl.errors import ControlSocketError
from rtctl.telemetry.reader import read

REPO = Path(__file__).resolve().parents[2]
READY = [0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0]
FAR = 1.1  # rad of waist: beyond the region
REGIONS = {"r0": (0.3, 0.8), "r1": (-0.8, -0.3)}  # waist; shoulder 0.2 … 0.9 for both
SHOULDER = (0.2, 0.9)
SIGN = {"r0": 1.0, "r1": -1.0}
LEASE_S, LEASE_MARGIN_S = 5.0, 0.25


def job(robot: str, cycles: int) -> dict:
    """The ``move`` fields of ``robot``'s job, ``cycles`` times: from the ready pose into its
    region of W, a pause there (1 s: work at the fixture), on through W to beyond it, a pause,
    straight back through W, a pause (2 s at each end: long enough for the path ahead to leave
    the gate's sight, so the lease is released and the other robot gets its turn)."""
    centre, far = list(READY), list(READY)
    centre[0], far[0] = SIGN[robot] * 0.55, SIGN[robot] * FAR
    waypoints, times, t = [], [], 0.0
    for _ in range(cycles):
        for point, leg, pause in ((centre, 1.0, 1.0), (far, 1.0, 2.0), (READY, 1.3, 2.0)):
            t += leg
            waypoints += [point, point]
            times += [t, t + pause]
            t += pause
    return {"waypoints": waypoints, "times": times}


def write_zone_cell(folder: Path) -> Path:
    """A two-robot cell file (robots r0, r1 holding the ready pose) with the shared zone."""
    zone = f'''
[leases]
duration_s = {LEASE_S}
margin_s = {LEASE_MARGIN_S}

[[zones]]
name = "fixture"
''' + "".join(f'''
[[zones.regions]]
robot = "{r}"
joints = ["waist", "shoulder"]
lo = [{lo}, {SHOULDER[0]}]
hi = [{hi}, {SHOULDER[1]}]
''' for r, (lo, hi) in REGIONS.items())
    return write_cell(folder, 2, extra=zone)


def status(run_dir: Path, robot: str) -> dict | None:
    """The robot's status, or None while its daemon is away or still starting."""
    try:
        reply = request(run_dir / f"{robot}.sock", "status", timeout=2.0)
    except ControlSocketError:
        return None
    return None if "starting" in reply else reply


def wait_for(predicate, what: str, timeout_s: float, every_s: float = 0.05):
    """Poll until ``predicate()`` is truthy (returns it); a deadline only so a broken run
    does not hang the suite (the failure says what was awaited)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(every_s)
    raise AssertionError(f"gave up waiting for {what} after {timeout_s:g} s")


class Track:
    """One robot's run from its telemetry: times on CLOCK_MONOTONIC (s), q, and per tick
    whether it is inside its region of W (from q alone)."""

    def __init__(self, run_dir: Path, robot: str, telemetry: Path | None = None, summary: Path | None = None):
        tel = read(telemetry or run_dir / f"{robot}.msgpack")
        s = json.loads((summary or run_dir / f"{robot}.summary.json").read_text())
        tick0 = s["clock"]["tick0_monotonic_ns"]
        self.period = 1.0 / tel.meta["rate_hz"]
        self.t = (tick0 + np.round(tel["t"] * 1e9)) * 1e-9
        self.q = tel["q"]
        self.qd = tel["qd"]
        self.waiting = tel["zones_waiting"][:, 0]
        lo, hi = REGIONS[robot]
        waist, shoulder = self.q[:, 0], self.q[:, 1]
        # depth in the box: > 0 outside (how far), < 0 inside
        self.depth = np.maximum.reduce([lo - waist, waist - hi, SHOULDER[0] - shoulder, shoulder - SHOULDER[1]])
        self.inside = self.depth < 0
        self.summary = s

    def entries(self) -> int:
        return int(np.count_nonzero(self.inside[1:] & ~self.inside[:-1]))

    def waits(self) -> int:
        w = self.waiting > 0
        return int(np.count_nonzero(w[1:] & ~w[:-1]) + w[0])

    def inside_times(self) -> np.ndarray:
        return self.t[self.inside]


def closest_approach(a: Track, b: Track) -> tuple[float, float]:
    """(the shortest time between one robot inside and the other inside — negative would be an
    overlap, counting each inside tick as the period around it —, the smallest max(depth a,
    depth b) at any tick of a with b's nearest tick: how close both came to being inside)."""
    ta, tb = a.inside_times(), b.inside_times()
    gap = np.inf
    if ta.size and tb.size:
        idx = np.clip(np.searchsorted(tb, ta), 1, tb.size - 1)
        nearest = np.minimum(np.abs(tb[idx] - ta), np.abs(tb[idx - 1] - ta))
        gap = float(nearest.min()) - a.period - b.period
    j = np.clip(np.searchsorted(b.t, a.t), 0, b.t.size - 1)
    both = np.maximum(a.depth, b.depth[j])
    return gap, float(both.min())


def never_both_inside(a: Track, b: Track) -> None:
    gap, depth = closest_approach(a, b)
    assert gap > 0, f"both robots inside W within one period of each other (gap {gap:.4f} s)"
    assert depth > 0, f"both inside W at one tick (max depth {depth:.4f})"


def arbiter_events(run_dir: Path) -> list[dict]:
    out = []
    for line in (run_dir / "arbiter.log").read_text().splitlines():
        try:
            out.append(json.loads(line))
        except ValueError:
            pass
    return out


__all__ = ["free_port", "job", "write_zone_cell", "status", "wait_for", "Track", "closest_approach", "never_both_inside",
           "arbiter_events", "LEASE_S", "LEASE_MARGIN_S"]
