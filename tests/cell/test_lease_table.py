"""The arbiter's lease table on a fake clock (rtctl/cell/lease.py; docs/cell.md, "Shared zones").

The safety property is checked against an independent model of what each robot may believe:
a robot counts its lease from when it sent the request (t_send + d), whatever the delays; the
table must never grant W to one robot while another's own view of its lease is still valid."""
from __future__ import annotations

import random

import pytest

from rtctl.cell.lease import LeaseTable, holder_expiry_ns

D, M = 1.0, 0.25
ZONES = {"W": ("a", "b")}


def started(now=0.0) -> LeaseTable:
    """A table past its quiet period with both robots confirmed outside."""
    t = LeaseTable(ZONES, D, M, now)
    later = now + D + M
    for robot in ("a", "b"):
        assert t.confirm("W", robot, later, held=False, inside=False)
    return t


def test_a_new_arbiter_grants_nothing_until_every_earlier_lease_has_expired_and_each_robot_is_confirmed():
    t = LeaseTable(ZONES, D, M, 10.0)
    assert not t.acquire("W", "a", 10.5).granted  # quiet: the previous arbiter's leases may run
    assert not t.confirm("W", "a", 11.0, held=False, inside=False)  # asked too early: proves nothing
    answer = t.acquire("W", "a", 11.3)
    assert not answer.granted and "b" in answer.reason  # b has not said it is outside
    assert t.confirm("W", "b", 11.3, held=False, inside=False)
    assert t.acquire("W", "a", 11.3).granted


def test_one_holder_at_a_time_renewals_and_release():
    t = started()
    first = t.acquire("W", "a", 2.0)
    assert first.granted
    assert not t.acquire("W", "b", 2.1).granted
    renewal = t.acquire("W", "a", 2.9)
    assert renewal.granted and renewal.seq > first.seq
    assert not t.acquire("W", "b", 3.5).granted  # renewed at 2.9: held until 2.9 + d + m
    assert not t.release("W", "a", first.seq, 3.6).granted  # a stale number frees nothing
    assert not t.acquire("W", "b", 3.6).granted
    assert t.release("W", "a", renewal.seq, 3.7).granted
    assert t.acquire("W", "b", 3.7).granted


def test_an_expired_lease_keeps_the_zone_until_its_holder_reports_outside_after_the_expiry():
    t = started()
    g = t.acquire("W", "a", 2.0)
    assert g.granted
    assert not t.acquire("W", "b", 2.0 + D + M - 1e-9).granted  # a's lease still counts
    assert not t.acquire("W", "b", 2.0 + D + M).granted  # expired, but a may be stopped inside
    assert not t.confirm("W", "a", 2.0 + D, held=False, inside=False)  # a query sent before the expiry
    assert not t.confirm("W", "a", 3.5, held=False, inside=True)  # inside: keeps W
    assert not t.confirm("W", "a", 3.5, held=True, inside=False)
    assert not t.acquire("W", "b", 9.0).granted  # (a killed daemon never answers: W stays a's)
    assert t.confirm("W", "a", 9.0, held=False, inside=False)
    assert t.acquire("W", "b", 9.0).granted


def test_no_report_counts_while_a_grant_could_still_be_valid_at_its_holder():
    """A grant given at g was asked for at some t_send <= g: the holder may count on it until
    t_send + d <= g + d, even if it arrives late (after the holder answered a status query
    with 'outside, nothing held'). So no report may count before g + d — with the margin m
    for the clocks' rates, not before g + d + m."""
    t = started()
    g = 2.0
    assert t.acquire("W", "a", g).granted
    for k in range(100):
        now = g + (D + M) * k / 100
        assert ("W", "a") not in t.to_confirm(now)
        assert not t.confirm("W", "a", now, held=False, inside=False)
        assert not t.acquire("W", "b", now).granted
    assert ("W", "a") in t.to_confirm(g + D + M)


def test_a_robot_stuck_inside_gets_its_zone_back():
    t = started()
    t.acquire("W", "a", 2.0)
    assert t.acquire("W", "a", 5.0).granted  # expired, unconfirmed — but it is a that asks


def test_inputs_are_validated():
    with pytest.raises(ValueError):
        LeaseTable({"W": ("a",)}, D, M, 0.0)
    with pytest.raises(ValueError):
        LeaseTable(ZONES, 0.0, M, 0.0)
    t = started()
    with pytest.raises(ValueError):
        t.acquire("V", "a", 3.0)
    with pytest.raises(ValueError):
        t.acquire("W", "c", 3.0)


def test_holder_expiry_counts_from_the_request():
    assert holder_expiry_ns(1_000, 0.5) == 500_001_000


def test_never_two_robots_believe_they_hold_the_zone_whatever_the_delays():
    """Random requests, renewals, releases and confirmations with random one-way delays (up to
    3 d). Each robot's belief is its own: a grant counts from its request's send time + d, and
    only if it arrives before then (a grant still on its way when the robot answers a status
    query arrives later); a robot that lets its lease lapse inside stays inside until a
    confirmation finds it outside. At every step no two robots may be 'possibly inside'."""
    for seed in range(300):
        rng = random.Random(seed)
        t = started()
        now = arbiter_now = 2.0  # (the arbiter handles messages in its own time order)
        valid = {"a": -1.0, "b": -1.0}  # each robot's own expiry
        stuck = {"a": False, "b": False}  # inside without a lease
        floor = {"a": 0, "b": 0}  # grants up to this number are refused (dropped)
        last = {"a": 0, "b": 0}
        in_flight = []  # (arrival, robot, sent, seq)
        for _ in range(300):
            now += rng.uniform(0.0, 0.4)
            for grant in [g for g in in_flight if g[0] <= now]:
                in_flight.remove(grant)
                arrival, r, sent, seq = grant
                if arrival < sent + D and seq > floor[r]:
                    valid[r], last[r], floor[r], stuck[r] = sent + D, seq, seq, False
            for r in "ab":  # a lease that lapses while the robot is inside leaves it stuck there
                if 0 < valid[r] <= now:
                    stuck[r] = rng.random() < 0.5
                    valid[r] = -1.0
            robot = rng.choice("ab")
            busy = any(g[1] == robot for g in in_flight)  # (the agent asks one thing at a time)
            up, down = rng.uniform(0, 3 * D), rng.uniform(0, 3 * D)
            action = rng.random()
            if action < 0.6 and not busy:
                arbiter_now = max(arbiter_now, now + up)
                answer = t.acquire("W", robot, arbiter_now)
                if answer.granted:
                    in_flight.append((arbiter_now + down, robot, now, answer.seq))
            elif action < 0.8 and not busy and not stuck[robot]:
                valid[robot], floor[robot] = -1.0, max(floor[robot], last[robot])  # the daemon drops first
                arbiter_now = max(arbiter_now, now + up)
                t.release("W", robot, last[robot], arbiter_now)
            elif action >= 0.8:
                arbiter_now = max(arbiter_now, now + up)
                held = valid[robot] > arbiter_now + down  # what it says when the query arrives
                t.confirm("W", robot, arbiter_now, held=held, inside=stuck[robot] or held)
            believers = [r for r in "ab" if valid[r] > now or stuck[r]]
            assert len(believers) <= 1, (seed, now, valid, stuck)


def test_the_arbiter_validates_every_request():
    from rtctl.cell.arbiter import parse_request

    ok = parse_request(b'{"op": "release", "zone": "W", "robot": "a", "seq": 4}')
    assert ok == {"op": "release", "zone": "W", "robot": "a", "seq": 4}
    assert parse_request(b'{"op": "acquire", "zone": "W", "robot": "a"}')["seq"] == 0
    for bad in (b"", b"[]", b"not json", b'{"op": "steal", "zone": "W", "robot": "a"}',
                b'{"op": "acquire", "zone": "W/x", "robot": "a"}', b'{"op": "acquire", "zone": "W", "robot": 3}',
                b'{"op": "release", "zone": "W", "robot": "a", "seq": -1}',
                b'{"op": "acquire", "zone": "W", "robot": "a", "until": 99}'):
        with pytest.raises(ValueError):
            parse_request(bad)
