"""A robot's shared zones in its loop, without processes (rtctl/cell/shared.py, gate.py):
the ``lease`` request's validation and its effect, the gate waiting at the border and moving on
with a lease, the guard forbidding the zone without one, and nothing allocated per tick.

The zone is checked against the region's box directly (numpy), the reference's velocity and
acceleration against finite differences of its position."""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

from allocations import growth_and_peak
from cell_helpers import REPO
from rtctl.cell.shared import SharedZones, for_run
from rtctl.config import load_config
from rtctl.control_socket.requests import InvalidRequest, validate
from rtctl.errors import ConfigError
from rtctl.guard.zones import Box
from rtctl.hal.joints import JointCommand, JointState
from rtctl.safety.faults import GuardVerdict
from rtctl.trajectory import JointLimits, through_waypoints

RUN = REPO / "configs" / "cell" / "puma560_cell_sim.toml"
DT = 0.002
LO, HI = np.array([0.3, 0.2]), np.array([0.8, 0.9])  # waist, shoulder
READY = np.array([0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0])


@pytest.fixture(scope="module")
def setup():
    cfg = load_config(RUN, sim=True)
    limits = JointLimits.for_run(cfg.model, cfg.trajectory)
    return cfg, limits


def zones(setup, lease_s=5.0) -> SharedZones:
    cfg, limits = setup
    z = SharedZones([("fixture", Box((0, 1), LO, HI))], cfg.model, limits, DT, lease_s)
    z.tick0_ns = time.monotonic_ns()  # loop time 0 is now
    return z


def depth(q) -> float:
    """> 0: outside the box by that much (max over the faces), < 0: inside."""
    return float(np.max(np.concatenate([LO - q[:2], q[:2] - HI])))


def run_gate(z, trajectory, seconds, grant_at=None):
    q, qd, qdd = np.zeros((3, 6))
    gate = z.gated(trajectory, 0.0)
    out = []
    for k in range(round(seconds / DT)):
        t = k * DT
        if grant_at is not None and t >= grant_at:
            z.expiry[0], z.gate_expiry[0] = 1e9, 1e9
        gate.sample(t, q, qd, qdd)
        out.append((t, q.copy(), qd.copy(), qdd.copy(), z.waiting[0]))
    return gate, out


def crossing(setup):
    far = READY.copy()
    far[0] = 1.1
    return through_waypoints([far], setup[1], start=READY)


def test_the_lease_request_is_validated():
    assert validate({"cmd": "lease", "zone": "W", "seq": 3, "expires_ns": 10}) == {
        "cmd": "lease", "zone": "W", "seq": 3, "expires_ns": 10}
    for bad in ({"zone": "", "seq": 1, "expires_ns": 1}, {"zone": "W", "seq": 0, "expires_ns": 1},
                {"zone": "W", "seq": True, "expires_ns": 1}, {"zone": "W", "seq": 1, "expires_ns": -1},
                {"zone": "W", "seq": 1, "expires_ns": 1.5}, {"zone": "W", "seq": 1}):
        with pytest.raises(InvalidRequest):
            validate({"cmd": "lease", **bad})


def test_a_grant_is_held_until_its_expiry_and_stale_or_late_grants_are_refused(setup):
    z = zones(setup)
    now = time.monotonic_ns()
    r = z.lease({"zone": "fixture", "seq": 2, "expires_ns": now + 4_000_000_000}, 0.0, READY, np.zeros(6))
    assert r["ok"] and r["held"]
    assert z.expiry[0] == pytest.approx(4.0 - 2 * DT, abs=0.05) and z.gate_expiry[0] == z.expiry[0] - z.horizon
    assert not z.lease({"zone": "fixture", "seq": 2, "expires_ns": now + 9_000_000_000}, 0.0, READY,
                       np.zeros(6))["ok"]  # not newer
    assert not z.lease({"zone": "fixture", "seq": 3, "expires_ns": now - 1}, 0.0, READY, np.zeros(6))["ok"]
    assert not z.lease({"zone": "fixture", "seq": 3, "expires_ns": now + 6_000_000_000}, 0.0, READY,
                       np.zeros(6))["ok"]  # longer than a lease can be (5 s)
    inside = READY.copy()
    inside[0] = 0.5
    assert not z.lease({"zone": "fixture", "seq": 2, "expires_ns": 0}, 0.0, inside, np.zeros(6))["ok"]
    assert z.lease({"zone": "fixture", "seq": 2, "expires_ns": 0}, 0.0, READY, np.zeros(6))["ok"]
    assert z.expiry[0] == -np.inf
    assert not z.lease({"zone": "fixture", "seq": 2, "expires_ns": now + 4_000_000_000}, 0.0, READY,
                       np.zeros(6))["ok"]  # dropped: refused from now on
    braking_in = READY.copy()
    braking_in[0] = 0.25
    assert z.status(0.0, braking_in, np.array([1.0, 0, 0, 0, 0, 0]))["fixture"]["inside"]  # stopping path enters


def test_without_a_lease_the_path_waits_at_the_border_and_moves_on_once_granted(setup):
    z = zones(setup)
    trajectory = crossing(setup)
    _, waited = run_gate(z, trajectory, 6.0)
    clearances = [depth(q) for _, q, *_ in waited]
    assert min(clearances) >= z.clearance - 1e-9  # never closer than the certified clearance
    assert waited[-1][2][0] == 0.0 and waited[-1][4] == 1.0  # at rest, waiting
    gate, went = run_gate(zones(setup), trajectory, trajectory.duration + 6.0, grant_at=3.0)
    assert gate.finished and went[-1][1][0] == pytest.approx(1.1)
    assert min(depth(q) for _, q, *_ in went) < 0  # it crossed
    # the time-scaled reference is consistent: q̇ and q̈ are the derivatives of q (q̈'s rate term
    # is the change of rate over the tick that ends at the sample: a backward difference)
    q = np.array([x[1] for x in went])
    qd = np.array([x[2] for x in went])
    qdd = np.array([x[3] for x in went])
    assert np.allclose(np.diff(q, axis=0) / DT, 0.5 * (qd[1:] + qd[:-1]), atol=2e-3)
    assert np.allclose(np.diff(qd, axis=0) / DT, qdd[1:], atol=0.2)
    assert np.max(np.abs(qdd)) <= 1.5 * np.max(setup[1].a_max) + 1e-9  # within a + a/2


def test_the_guard_forbids_the_zone_without_a_lease(setup):
    z = zones(setup)
    guard = z.guard(None)
    state, command = JointState(6), JointCommand(6)
    state.position[:] = READY
    state.position[0] = 0.25
    state.velocity[0] = 1.0  # stopping path into the zone
    assert guard.check(0.0, state, command) == GuardVerdict.STOP
    assert "fixture" in guard.reason and guard.event()["zone"] == "fixture"
    z.expiry[0] = 10.0
    assert guard.check(0.0, state, command) == GuardVerdict.PASS
    assert guard.check(10.0, state, command) == GuardVerdict.STOP  # expired


def test_nothing_is_allocated_per_tick(setup):
    z = zones(setup)
    gate = z.gated(crossing(setup), 0.0)
    guard = z.guard(None)
    state, command = JointState(6), JointCommand(6)
    state.position[:] = READY
    q, qd, qdd = np.zeros((3, 6))
    gate.sample(0.0, q, qd, qdd)
    guard.check(0.0, state, command)
    k = [0]

    def tick():
        k[0] += 1
        gate.sample(k[0] * DT, q, qd, qdd)
        guard.check(k[0] * DT, state, command)

    growth, _ = growth_and_peak(tick, 2000)
    assert growth <= 64


def test_a_lease_shorter_than_twice_the_stopping_horizon_is_a_config_error(setup, tmp_path):
    from zone_helpers import write_zone_cell

    path = write_zone_cell(tmp_path)
    path.write_text(path.read_text().replace("duration_s = 5.0", "duration_s = 1.0"))
    cfg, limits = setup
    args = SimpleNamespace(cell=str(path), cell_robot="r0")
    with pytest.raises(ConfigError) as e:
        for_run(args, cfg, limits)
    assert e.value.key_path == "leases.duration_s" and "twice" in e.value.expected
    args.cell_robot = "r9"
    with pytest.raises(ConfigError) as e:
        for_run(args, cfg, limits)
    assert e.value.key_path == "--cell-robot"


def test_cell_status_shows_who_holds_and_who_waits():
    from rtctl.cell.commands import format_replies

    base = {"ok": True, "t": 1.0, "verdict": "OK", "estopped": False, "faults": []}
    table = format_replies("c", {"r0": base | {"zones": {"fixture": {"held": True, "waiting": False}}},
                                 "r1": base | {"zones": {"fixture": {"held": False, "waiting": True}}}})
    lines = table.splitlines()
    assert "shared zones" in lines[1]
    assert "fixture held" in lines[2] and "fixture waiting" in lines[3]


def test_a_lease_about_to_end_does_not_let_the_path_start_into_the_zone(setup):
    """Within the stopping horizon of its end a lease still lets the guard pass but not the
    gate: the path would not come to rest before the lease ends."""
    z = zones(setup)
    z.expiry[0] = 1.0  # held by the guard until t = 1 s, by the gate never (1 s < the horizon)
    z.gate_expiry[0] = z.expiry[0] - z.horizon
    _, out = run_gate(z, crossing(setup), 3.0)
    assert min(depth(q) for _, q, *_ in out) >= z.clearance - 1e-9
    assert out[-1][4] == 1.0
    assert z.guard(None).check(0.5, JointState(6), JointCommand(6)) == GuardVerdict.PASS


def test_a_fast_approach_still_stops_at_the_border(setup):
    """From far away the path reaches W at speed: braking takes the whole room it has."""
    start, far = READY.copy(), READY.copy()
    start[0], far[0] = -2.5, 2.5
    trajectory = through_waypoints([far], setup[1], start=start)
    z = zones(setup)
    _, out = run_gate(z, trajectory, 6.0)
    speeds = [abs(qd[0]) for _, _, qd, *_ in out]
    assert max(speeds) > 2.0  # (it did come fast)
    assert min(depth(q) for _, q, *_ in out) >= z.clearance - 1e-9
    assert out[-1][2][0] == 0.0
