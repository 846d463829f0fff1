"""The fixed-rate ticker: absolute deadlines, skip-not-catch-up overruns, safe-stop signal.

Tick ``k`` is due at ``start + k·period/f`` on the monotonic clock (``f`` the real-time
factor), so timing errors never accumulate. A tick that ends after the next deadline is an
*overrun*: the missed deadlines are skipped, never caught up — the next tick is the first
grid point still in the future, so a slow tick is followed by one normal tick, not a burst.
``max_consecutive_overruns`` overruns in a row request a controlled safe stop: ``end_tick``
returns True and the loop acts on it (nothing is raised inside the tick).

With ``realtime_factor = 0`` (lock-step with the embedded simulator) nothing sleeps: tick
``k`` simply follows tick ``k − 1`` and simulated time is ``k·period``, bit-for-bit.

The loop, with ``PHASES`` = read, update, safety, write, record::

    ticker.start()
    while running:
        k = ticker.wait()                       # sleeps to tick k's deadline
        ...read...;    ticker.mark(READ)
        ...update (controller c if ticker.due(c.divisor))...; ticker.mark(UPDATE)
        ...;           ticker.mark(SAFETY); ...; ticker.mark(WRITE); ...; ticker.mark(RECORD)
        if ticker.end_tick():                   # True: too many overruns in a row
            safe_stop()
    summary = ticker.summary()
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import structlog

from rtctl.timing.busy import BusyMeter
from rtctl.timing.clock import MonotonicClock
from rtctl.timing.stats import LoopStats

PHASES = ("read", "update", "safety", "write", "record")
READ, UPDATE, SAFETY, WRITE, RECORD = range(len(PHASES))
# the daemon's loop adds one: serving the control socket and the move planner's pipe, so that
# what commands cost the loop shows in its own statistics
DAEMON_PHASES = (*PHASES, "serve")
SERVE = len(PHASES)
LOG_INTERVAL_NS = 1_000_000_000  # at most one overrun record per second

log = structlog.get_logger("rtctl.scheduler")


def due(prev_tick: int, tick: int, divisor: int) -> bool:
    """Whether a controller running every ``divisor`` ticks runs at ``tick``.

    It runs when the grid crossed a multiple of ``divisor`` since the previous executed
    tick, so a skipped period delays a slow controller's update instead of dropping it,
    and it never runs twice for one slot. ``due(-1, 0, d)`` is True: everything runs first.
    """
    return tick // divisor != prev_tick // divisor


OVERRUN_LIMIT = 50  # consecutive overruns → a controlled safe stop ([loop] overrun_limit's default)
SPIN_MARGIN_NS = 200_000  # the spin before each deadline ([loop] spin_us's default; busy.py: why not more)


class Ticker:
    """Paces the loop and keeps its statistics.

    ``period_ns``: the control period (simulated time per tick). ``realtime_factor``: 1.0
    runs on the wall clock, f > 0 makes simulated time run f × real time (tick k due at
    ``start + k·period/f``, f taken as the nearest fraction with a denominator up to 10⁹: exact
    integer deadlines), 0 never sleeps. ``clock``: anything with ``now_ns()`` and
    ``sleep_until_ns()`` (default :class:`MonotonicClock` with ``spin_margin_ns``).
    ``busy``: how busy the loop keeps its core (:class:`~rtctl.timing.busy.BusyMeter`; paced
    modes only — lock-step never sleeps).
    """

    def __init__(
        self,
        period_ns: int,
        *,
        realtime_factor: float = 1.0,
        max_consecutive_overruns: int = OVERRUN_LIMIT,
        spin_margin_ns: int = SPIN_MARGIN_NS,
        clock=None,
        phases=PHASES,
        busy: BusyMeter | None = None,
    ):
        if period_ns <= 0:
            raise ValueError("period_ns must be > 0")
        if realtime_factor < 0:
            raise ValueError("realtime_factor must be >= 0")
        if max_consecutive_overruns < 1:
            raise ValueError("max_consecutive_overruns must be >= 1")
        self.period_ns = int(period_ns)
        self.realtime_factor = float(realtime_factor)
        self.max_consecutive_overruns = int(max_consecutive_overruns)
        self.clock = clock if clock is not None else MonotonicClock(spin_margin_ns)
        self.phases = tuple(phases)
        self.stats = LoopStats(self.phases)
        self.busy = busy if busy is not None else BusyMeter()
        # tick k is due at start + k·period·den // num: exact integers, no drift
        f = Fraction(self.realtime_factor).limit_denominator(10**9)
        if f == 0 < self.realtime_factor:
            raise ValueError(f"realtime_factor {realtime_factor} is too small (0 means lock-step)")
        self._paced = f > 0
        self._grid_num, self._grid_den = f.numerator, self.period_ns * f.denominator
        self._now = self.clock.now_ns  # (one attribute lookup less per mark)
        self.stamps = np.zeros(len(self.phases), dtype=np.int64)  # the clock at each phase's mark
        # the last closed tick's phase times, filled in place by end_tick (a telemetry source)
        self.phase_ns = np.zeros(len(self.phases), dtype=np.int64)
        self.tick = -1  # index on the grid of the tick in progress (jumps over skipped ones)
        self.prev_tick = -1
        self.lateness_ns = 0
        self.consecutive_overruns = 0
        self.stop_requested = False
        self._next_tick = 0
        self._start_ns = self._wake_ns = self._end_ns = 0
        self._last_log_ns: int | None = None
        self._suppressed = 0

    def deadline_ns(self, k: int) -> int:
        """Wall-clock deadline of tick ``k`` (paced modes only)."""
        return self._start_ns + k * self._grid_den // self._grid_num

    def start(self) -> None:
        """Anchor the grid: tick 0 is due now. (First the statistics' kernel is loaded, on a
        scratch record: the first tick must not pay for it.)"""
        LoopStats(self.phases).record(0, [0] * len(self.phases), 0)
        self._start_ns = self._wake_ns = self._end_ns = self.clock.now_ns()
        self._next_tick = 0
        self.busy.start(self._start_ns)

    def wait(self) -> int:
        """Sleep until the next tick's deadline (not in lock-step); return its grid index."""
        k = self._next_tick
        if self._paced:
            deadline = self._start_ns + k * self._grid_den // self._grid_num
            self.clock.sleep_until_ns(deadline)
            now = self.clock.now_ns()
            self.lateness_ns = now - deadline
        else:
            now = self.clock.now_ns()
        self.prev_tick, self.tick = self.tick, k
        self._wake_ns = now  # a stamp not after this is a phase not marked this tick: it counts 0
        return k

    def mark(self, phase: int) -> None:
        """End of phase ``phase`` (an index into ``phases``); its time, since the previous mark
        (or the wake), is worked out when the tick ends."""
        self.stamps[phase] = self._now()

    def due(self, divisor: int) -> bool:
        """Whether a controller with this rate divisor runs in the current tick (see :func:`due`)."""
        return due(self.prev_tick, self.tick, divisor)

    @property
    def wake_ns(self) -> int:
        """When the current tick woke up, on the clock (``start()``'s time before the first)."""
        return self._wake_ns

    @property
    def sim_time_s(self) -> float:
        """Simulated time of the current tick: ``k·period``."""
        return self.tick * self.period_ns * 1e-9

    def end_tick(self) -> bool:
        """Close the tick: record statistics, apply the overrun policy.

        Returns True once ``max_consecutive_overruns`` ticks in a row have overrun; the
        loop then performs its controlled safe stop. Stays True (latched).
        """
        end = self._end_ns = self.clock.now_ns()
        k_next = self.tick + 1
        if self._paced:
            self.stats.record_marks(self.stamps, self._wake_ns, end, self.lateness_ns, self.phase_ns)
            self.busy.sample(end)
            next_deadline = self._start_ns + k_next * self._grid_den // self._grid_num
            if end > next_deadline:
                # the first grid point not yet past: m with deadline(m) ≥ end, i.e. m·den/num ≥ end − start
                # (ending exactly on a deadline is on time for that tick, as for the next one)
                m = -(-(end - self._start_ns) * self._grid_num // self._grid_den)
                self._overrun(end, end - next_deadline, m - k_next)
                k_next = m
            else:
                self.consecutive_overruns = 0
        else:
            self.stats.record_marks(self.stamps, self._wake_ns, end, None, self.phase_ns)
        self._next_tick = k_next
        return self.stop_requested

    def _overrun(self, now: int, late_ns: int, skipped: int) -> None:
        self.consecutive_overruns += 1
        self.stats.record_overrun(skipped, self.consecutive_overruns)
        if self._last_log_ns is None or now - self._last_log_ns >= LOG_INTERVAL_NS:
            log.warning(
                "tick overrun",
                tick=self.tick,
                late_us=late_ns / 1e3,
                skipped_periods=skipped,
                consecutive=self.consecutive_overruns,
                phases_us={name: int(t) / 1e3 for name, t in zip(self.phases, self.phase_ns)},
                wake_lateness_us=self.lateness_ns / 1e3,
                suppressed=self._suppressed,
            )
            self._last_log_ns = now
            self._suppressed = 0
        else:
            self._suppressed += 1
        if self.consecutive_overruns >= self.max_consecutive_overruns and not self.stop_requested:
            self.stop_requested = True
            log.error(
                "overrun limit reached, requesting safe stop",
                tick=self.tick,
                consecutive=self.consecutive_overruns,
                limit=self.max_consecutive_overruns,
            )

    def summary(self) -> dict:
        """JSON-able statistics of the run so far (see :meth:`LoopStats.summary`)."""
        end = self._end_ns
        if self._paced and self.tick >= 0:  # a run lasts until its last period is over
            end = max(end, self.deadline_ns(self.tick + 1))
        return self.stats.summary(
            wall_time_s=(end - self._start_ns) / 1e9,
            period_s=self.period_ns / 1e9,
            realtime_factor=self.realtime_factor,
        ) | {"safe_stop_requested": self.stop_requested,
             "core_busy": self.busy.summary(self._end_ns) if self._paced and self.tick >= 0 else None}
