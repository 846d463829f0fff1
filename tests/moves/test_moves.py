"""The loop's side of ``move`` (rtctl.moves.pending) against a real planner process: a move is
swapped in at a tick without a jump, a second one is busy, stop/estop/reset cancel it, a dead
planner is named and replaced, and a large plan reaches the loop in pieces it never waits for."""
from __future__ import annotations

import multiprocessing
import time

import numpy as np
import pytest

from rtctl.config import load_config
from rtctl.trajectory import JointLimits
from rtctl.moves import wire
from rtctl.moves.pending import Moves
from rtctl.trajectory import hold, through_waypoints
from runtime_helpers import BASE

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

PERIOD = 0.001
HOME = np.radians([0, 45, -180, 0, 45, 0])
TARGET = np.radians([20, 30, -160, 10, 60, 20])


@pytest.fixture
def planner(write_config):
    cfg = load_config(write_config(BASE))
    limits = JointLimits.for_run(cfg.model, cfg.trajectory)
    moves = Moves(cfg, limits, PERIOD)
    moves.start()
    moves.warm()
    yield moves, limits
    moves.close()


def move(q, **extra):
    return {"cmd": "move", "q": np.asarray(q, float), "waypoints": None, "duration": None, "times": None,
            "deg": False, **extra}


def run_ticks(moves, trajectory, t, until, paced=True, timeout=30.0):
    """Tick as the loop does (swap before, poll after) until ``until(reply)``; returns the
    trajectory in force, the time, and the references sampled each tick."""
    refs, end = [], time.monotonic() + timeout
    q, qd, qdd = np.zeros(6), np.zeros(6), np.zeros(6)
    while not until() and time.monotonic() < end:
        planned = moves.swap(t)
        if planned is not None:
            trajectory = planned
        trajectory.sample(t, q, qd, qdd)
        refs.append((t, q.copy(), qd.copy(), qdd.copy()))
        moves.poll(t, trajectory)
        time.sleep(PERIOD if paced else PERIOD / 5)  # unpaced: loop time runs 5× ahead of the wall
        t += PERIOD
    return trajectory, t, refs


def test_a_move_asked_while_moving_starts_ahead_with_position_velocity_and_acceleration_continuous(planner):
    moves, limits = planner
    running = through_waypoints([HOME, TARGET], limits, start=HOME)
    t_ask = 0.3 * running.duration  # mid-motion
    reply = moves.request(move(HOME), t_ask, running)
    new, t, refs = run_ticks(moves, running, t_ask, lambda: reply.reply is not None)
    assert reply.reply["ok"], reply.reply
    t0 = reply.reply["t_start"]
    assert t0 > t_ask and new.t_start == t0  # planned from ahead, not from the moment it was asked
    for a, b in zip(running.state_at(t0), new.state_at(t0)):
        np.testing.assert_allclose(a, b, atol=1e-9)  # the swap continues the reference exactly
    ts = np.array([r[0] for r in refs])
    qs = np.array([r[1] for r in refs])
    steps = np.abs(np.diff(qs, axis=0)) / np.diff(ts)[:, None]
    assert np.all(steps <= limits.v_max * 1.01), "a jump in the reference at the swap"
    np.testing.assert_allclose(new.state_at(new.t_end)[0], HOME, atol=1e-12)


def test_a_move_from_rest_starts_at_the_tick_after_its_plan_arrives(planner):
    moves, limits = planner
    resting = hold(HOME, 0.0)
    reply = moves.request(move(TARGET, duration=2.0), 1.0, resting)
    # not paced: loop time runs far ahead of the planning, as in a lock-step run
    new, t, _ = run_ticks(moves, resting, 1.0, lambda: reply.reply is not None, paced=False)
    r = reply.reply
    assert r["ok"] and r["t_start"] > 1.0 + PERIOD and r["t_end"] - r["t_start"] == pytest.approx(2.0)
    for x, want in zip(new.state_at(r["t_start"]), (HOME, 0.0, 0.0)):
        np.testing.assert_allclose(x, want, atol=1e-12)


def test_a_second_move_while_one_is_pending_is_answered_busy_with_the_reason(planner):
    moves, _ = planner
    resting = hold(HOME, 0.0)
    first = moves.request(move(TARGET), 0.0, resting)
    second = moves.request(move(HOME), 0.01, resting)
    assert second["ok"] is False and second["busy"] and "busy: a move asked for 0.010 s ago" in second["error"]
    run_ticks(moves, resting, 0.01, lambda: first.reply is not None)
    assert first.reply["ok"]


@pytest.mark.parametrize("reason", ["operator e-stop", "stop requested", "reset"])
def test_stop_estop_and_reset_cancel_a_pending_move_and_its_client_hears_why(planner, reason):
    moves, _ = planner
    resting = hold(HOME, 0.0)
    pending = moves.request(move(TARGET), 0.0, resting)
    moves.cancel(reason)
    assert pending.reply == {"ok": False, "error": f"move cancelled: {reason}"}
    _, _, refs = run_ticks(moves, resting, 0.0, lambda: False, timeout=0.5)  # its plan arrives: ignored
    assert all(np.array_equal(r[1], HOME) for r in refs)
    after = moves.request(move(TARGET), refs[-1][0], resting)  # the planner serves the next one
    run_ticks(moves, resting, refs[-1][0], lambda: after.reply is not None)
    assert after.reply["ok"]


def test_a_refused_move_is_answered_with_the_limit_it_breaks(planner):
    moves, _ = planner
    resting = hold(HOME, 0.0)
    pending = moves.request(move(TARGET, duration=0.01), 0.0, resting)
    run_ticks(moves, resting, 0.0, lambda: pending.reply is not None)
    assert not pending.reply["ok"] and pending.reply["error"].startswith("move refused: ")


def test_a_planner_that_dies_refuses_its_move_naming_it_and_the_next_move_starts_a_new_one(planner):
    moves, _ = planner
    resting = hold(HOME, 0.0)
    run_ticks(moves, resting, 0.0, lambda: False, timeout=0.2)
    moves._process.kill()
    pending = moves.request(move(TARGET), 0.0, resting)
    run_ticks(moves, resting, 0.0, lambda: pending.reply is not None)
    assert not pending.reply["ok"] and "the planner process exited" in pending.reply["error"]
    again = moves.request(move(TARGET), 1.0, resting)
    run_ticks(moves, resting, 1.0, lambda: again.reply is not None)
    assert again.reply["ok"], again.reply


def test_a_large_message_reaches_the_reader_in_pieces_it_never_waits_for():
    reader, writer = multiprocessing.Pipe()
    inbox = wire.Inbox(reader)
    big = ("plan", np.arange(100_000, dtype=float))  # 0.8 MB: more than a socket buffer holds
    pieces = []
    fake = type("Fake", (), {"send_bytes": lambda self, b: pieces.append(bytes(b))})()
    wire.send(fake, big)
    assert len(pieces) > 40 and max(map(len, pieces)) <= wire.PIECE
    for piece in pieces[:-1]:
        writer.send_bytes(piece)
        assert inbox.take() is None  # part of a message: nothing yet, and no wait for the rest
    writer.send_bytes(pieces[-1])
    kind, data = inbox.take()
    assert kind == "plan" and np.array_equal(data, big[1]) and inbox.take() is None
