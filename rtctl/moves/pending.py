"""The loop's side of a ``move``: hand it to the planner process, swap the result in at a tick.

What the loop does per tick is bounded and small: :meth:`Moves.swap` (before the tick) compares
one number; :meth:`Moves.poll` (after it, with the control socket) reads the planner's answer
when the pipe has one — a few kB of knots and coefficients. The planning itself never runs on
the loop's thread, so a move cannot delay a tick however long it takes.

Where a move starts. The running trajectory is known ahead of time, so a move is planned from
the reference the loop *will* have at ``t0`` and swapped in at the first tick at or after
``t0`` (position, velocity and acceleration continuous):

* the reference at rest from now on (the running trajectory has ended, or holds): ``t0`` is
  now, and the plan is shifted in time to the tick after it arrives — from rest, where the
  robot starts waiting makes no difference;
* the reference moving: ``t0`` lies ahead by twice the longest recent planning time (at least
  ``MIN_LEAD_S``). A plan that arrives after ``t0`` is planned again from further ahead, at
  most ``ATTEMPTS`` times, then the move is answered "busy" with the reason.

While a move is pending the loop runs the old trajectory; a second ``move`` is answered
"busy"; ``stop``, ``estop`` and ``reset`` cancel it (its client hears why). A planner that
takes longer than ``PLAN_TIMEOUT_S`` or dies is replaced at the next move, and the pending one
is refused naming the cause.
"""
from __future__ import annotations

import math
import multiprocessing
import pickle
import time

import structlog

from rtctl.control_socket.connection import Deferred
from rtctl.moves.wire import Inbox
from rtctl.trajectory import JointTrajectory

MIN_LEAD_S = 0.05  # of loop time: a move from motion starts at least this far ahead
ATTEMPTS = 3
PLAN_TIMEOUT_S = 30.0  # of wall time: past it the planner is presumed stuck and replaced
STATUS_EVERY_S = 0.5  # how often a pending plan checks that the planner is alive

log = structlog.get_logger("rtctl.moves")


class _Move:
    __slots__ = ("reply", "req", "ident", "t0", "asked_at", "sent_at", "planner_ready", "attempt", "trajectory",
                 "extra")

    def __init__(self, reply: Deferred, req: dict, asked_at: float):
        self.reply, self.req, self.asked_at = reply, req, asked_at
        self.ident, self.t0, self.attempt = 0, asked_at, 0
        self.sent_at, self.planner_ready = asked_at, False
        self.trajectory: JointTrajectory | None = None  # planned, waiting for its tick
        self.extra: dict = {}


class Moves:
    """``request`` from the control-socket handler, ``poll`` after every tick, ``swap`` before."""

    def __init__(self, cfg, limits, period: float):
        self._payload = pickle.dumps((cfg, limits))
        self._loop_cpus = tuple(cfg.loop.rt.cpus)
        self.period = period
        self._process = self._conn = self._inbox = None
        self._ready = self._warming = False
        self._ident = 0
        self._in_flight: int | None = None  # the request the planner works on (one at a time: a send never waits)
        self._sent_wall = 0.0  # when it was sent (monotonic wall time)
        self.move: _Move | None = None
        self.recent_s = MIN_LEAD_S / 2  # the longest of the recent plans, in loop time
        self._swap_at = math.inf  # loop time of the next swap (inf: none)
        self._next_check = 0.0

    # -- the planner process ------------------------------------------------------------
    def start(self) -> None:
        """Spawn the planner: before the real-time settings apply (it inherits none of them)."""
        from rtctl.moves import worker

        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._inbox = Inbox(self._conn)
        self._process = ctx.Process(target=worker.main, args=(child, self._payload, self._loop_cpus),
                                    name="rtctl-planner", daemon=True)
        self._process.start()
        child.close()
        self._ready = self._warming = False

    def warm(self) -> None:
        """Let the planner load its kernels (once the warm-up has compiled them); once."""
        if not self._warming:
            self._warming = True
            self._conn.send(("warm",))

    def close(self) -> None:
        """Stop the planner at once — it holds nothing to clean up (numba writes its cache
        atomically), and one still loading its kernels would not read a polite request for a
        while — and refuse a pending move."""
        self.cancel("the daemon is stopping")
        if self._process is not None:
            self._process.kill()
            self._process.join()
            self._conn.close()
            self._process = self._conn = self._inbox = None

    # -- from the control socket's handler ----------------------------------------------
    def request(self, req: dict, t: float, current: JointTrajectory) -> Deferred | dict:
        """A validated ``move``: a :class:`Deferred` answered once the move is swapped in (or
        refused), or at once "busy" while another move is pending."""
        if self.move is not None:
            what = "planned" if self.move.trajectory is None else "about to start"
            return {"ok": False, "busy": True,
                    "error": f"busy: a move asked for {t - self.move.asked_at:.3f} s ago is being {what}; "
                             "send this one when it is answered"}
        if self._process is None or not self._process.is_alive():
            self.start()
            self.warm()
        self.move = _Move(Deferred(), req, t)
        if self._in_flight is None:  # else it goes when the planner has finished a cancelled move
            self._send(t, current)
        return self.move.reply

    def cancel(self, reason: str) -> None:
        if self.move is not None:
            self._finish(self.move, {"ok": False, "error": f"move cancelled: {reason}"})

    @property
    def state(self) -> str | None:
        """For ``status``: None, "planning" or "starting"."""
        if self.move is None:
            return None
        return "planning" if self.move.trajectory is None else "starting"

    # -- from the loop ------------------------------------------------------------------
    def swap(self, t: float) -> JointTrajectory | None:
        """Before the tick at ``t``: the trajectory to run from this tick on, if one is due."""
        if t < self._swap_at:
            return None
        move = self.move
        self._finish(move, {"ok": True, "t_start": move.trajectory.t_start, "t_end": move.trajectory.t_end,
                            **move.extra})
        return move.trajectory

    def poll(self, t: float, current: JointTrajectory) -> None:
        """After the tick at ``t``: take the planner's answer if it has come (never waits)."""
        if self._in_flight is None:
            return
        move = self.move
        try:
            while self._in_flight is not None:
                msg = self._inbox.take()
                if msg is None:
                    break
                if msg[0] == "ready":
                    self._ready = True
                    log.info("move planner ready", seconds=round(msg[1], 2))
                    continue
                self._in_flight = None
                if move is not None and msg[0] == move.ident:
                    self._answer(move, msg, t, current)
        except (EOFError, OSError):
            self._planner_lost(f"the planner process exited ({self._process.exitcode})")
            return
        move = self.move
        if move is not None and move.ident == 0 and self._in_flight is None:
            self._send(t, current)  # it waited for a cancelled move's plan
        if self._in_flight is not None and t >= self._next_check:
            self._next_check = t + STATUS_EVERY_S
            if time.monotonic() - self._sent_wall > PLAN_TIMEOUT_S:
                self._planner_lost(f"no plan after {PLAN_TIMEOUT_S:g} s")
            elif not self._process.is_alive():
                self._planner_lost(f"the planner process exited ({self._process.exitcode})")

    # -- inside ---------------------------------------------------------------------------
    def _answer(self, move: _Move, msg: tuple, t: float, current: JointTrajectory) -> None:
        if msg[1] == "refused":
            self._finish(move, {"ok": False, "error": msg[2]})
            return
        _, _, knots, coeffs, extra, _ = msg
        took = t - move.sent_at
        if move.planner_ready:  # (a plan that waited for the planner to start says nothing of the next)
            self.recent_s = max(0.5 * self.recent_s, took)  # forget old slow plans, slowly
        t_next = t + self.period
        if t_next <= move.t0:  # in time: swap at t0
            move.trajectory = JointTrajectory(knots, coeffs)
        elif current.t_end <= move.t0:  # from rest: start at the next tick
            move.trajectory = JointTrajectory(knots + (t_next - move.t0), coeffs)
        elif move.attempt < ATTEMPTS:
            self._send(t, current)
            return
        else:
            self._finish(move, {"ok": False, "busy": True, "error": (
                f"busy: planning took {took:.3f} s of loop time, {ATTEMPTS} times too long for the robot's "
                "current motion; send the move again (or when the robot is at rest)")})
            return
        move.extra = extra
        self._swap_at = move.trajectory.t_start

    def _finish(self, move: _Move, reply: dict) -> None:
        move.reply.resolve(reply)
        self.move, self._swap_at = None, math.inf

    def _planner_lost(self, why: str) -> None:
        log.error("move planner lost", reason=why)
        self._process.kill()
        self._process.join()
        self._process, self._in_flight = None, None
        if self.move is not None:
            self._finish(self.move, {"ok": False, "error": f"move refused: {why}; the next move starts a new planner"})

    def _lead(self) -> float:
        return max(MIN_LEAD_S, 2.0 * self.recent_s)

    def _send(self, t: float, current: JointTrajectory) -> None:
        """(Re)plan the pending move from the reference the running trajectory will have at
        ``t0``: now when it is at rest from now on, else ahead by the lead."""
        move = self.move
        t0 = t if current.t_end <= t else t + self.period + self._lead()
        self._ident += 1
        self._in_flight = self._ident
        move.ident, move.t0, move.sent_at, self._sent_wall = self._ident, t0, t, time.monotonic()
        move.attempt += 1
        move.planner_ready = self._ready
        q, qd, qdd = current.state_at(t0)
        self._conn.send((move.ident, t0, q, qd, qdd, move.req))
