"""A ``running`` line now and then while the loop runs, so that an operator's terminal is
never silent for long: loop time, ticks, overruns and the current tracking error.

Logged from the loop thread at a tick boundary, once per ``interval_s`` of wall time (loop time
would flood the log when a simulation runs faster than real time): each tick costs one
comparison, and only the tick that logs formats a line. ``rtctl run`` logs one every second on
a terminal and none in JSON logs (journald has the control socket's ``status`` for that),
unless ``--progress`` says otherwise.
"""
from __future__ import annotations

import math

import numpy as np
import structlog

log = structlog.get_logger("rtctl.daemon")

CONSOLE_INTERVAL_S = 1.0


def interval_for(option: float | None, fmt: str) -> float:
    """The interval in s (0: never) from ``--progress`` (None: the default for ``fmt``)."""
    if option is not None:
        return option
    return CONSOLE_INTERVAL_S if fmt == "console" else 0.0


class Progress:
    """Call :meth:`tick` once per tick after ``ticker.start()``."""

    def __init__(self, interval_s: float, duration: float | None, ticker, state, ref, tracking: bool = True):
        self.interval_ns = int(interval_s * 1e9)
        self.tracking = tracking  # (a leg's automaton follows no reference: no tracking error)
        self.duration, self.ticker, self.state, self.ref = duration, ticker, state, ref
        self.due_ns = ticker.wake_ns + self.interval_ns if self.interval_ns else math.inf

    def tick(self, t: float) -> None:
        if self.ticker.wake_ns < self.due_ns:
            return
        self.due_ns += self.interval_ns * ((self.ticker.wake_ns - self.due_ns) // self.interval_ns + 1)
        fields = {} if self.duration is None else {"duration": self.duration}  # (none: until a stop)
        if self.tracking:  # (allocates: once per interval)
            fields["tracking_error"] = float(f"{float(np.max(np.abs(self.ref.q - self.state.position))):.3g}")
        log.info("running", t=round(t, 3), **fields, ticks=self.ticker.stats.ticks,
                 overruns=self.ticker.stats.overruns)
