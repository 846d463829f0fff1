"""Clocks the scheduler runs on: the real monotonic clock, and a fake one for tests.

A clock is any object with ``now_ns() -> int`` and ``sleep_until_ns(deadline_ns)``,
both on the same (monotonic) time line. The scheduler never sleeps for a *duration*:
it asks to be woken at an absolute deadline, so a preemption between reading the
clock and going to sleep cannot push the whole grid late.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import errno
import time

_CLOCK_MONOTONIC = 1  # same clock as time.monotonic_ns() (Linux <time.h>)
_TIMER_ABSTIME = 1


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


def _load_clock_nanosleep():
    """libc's clock_nanosleep, or None where there is none (then time.sleep is used)."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        fn = libc.clock_nanosleep
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.POINTER(_Timespec), ctypes.c_void_p]
    fn.restype = ctypes.c_int
    return fn


class MonotonicClock:
    """``time.monotonic_ns`` with an absolute sleep: sleep until ``deadline − spin_margin``,
    then busy-spin to the deadline.

    The kernel wakes a sleeping thread late by its timer slack (50 µs by default for
    SCHED_OTHER) plus the scheduling latency; the spin margin absorbs that at the price of
    burning up to ``spin_margin_ns`` of CPU per tick. The sleep itself is
    ``clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)`` through ctypes (which releases the
    GIL); a signal interrupts it with EINTR, the Python handler runs, and the sleep resumes —
    unless ``interrupted()`` (optional) then returns True: the sleep ends early, so a stop
    requested by a signal handler is acted on at once, however long the period.
    """

    def __init__(self, spin_margin_ns: int, interrupted=None):  # (the spin: [loop] spin_us)
        if spin_margin_ns < 0:
            raise ValueError("spin_margin_ns must be >= 0")
        self.spin_margin_ns = int(spin_margin_ns)
        self.interrupted = interrupted
        self._nanosleep = _load_clock_nanosleep()
        self._ts = _Timespec()  # reused every tick: no per-tick allocation
        self._ts_ref = ctypes.byref(self._ts)

    now_ns = staticmethod(time.monotonic_ns)

    def sleep_until_ns(self, deadline_ns: int) -> None:
        wake_ns = deadline_ns - self.spin_margin_ns
        if time.monotonic_ns() < wake_ns:
            if self._nanosleep is None:
                time.sleep(max(0, wake_ns - time.monotonic_ns()) / 1e9)
            else:
                self._ts.tv_sec, self._ts.tv_nsec = divmod(wake_ns, 1_000_000_000)
                while self._nanosleep(_CLOCK_MONOTONIC, _TIMER_ABSTIME, self._ts_ref, None) == errno.EINTR:
                    # a signal: its Python handler runs before the call below does
                    if self.interrupted is not None and self.interrupted():
                        return
                    # otherwise keep the same absolute deadline
        while time.monotonic_ns() < deadline_ns:
            pass


class FakeClock:
    """A deterministic clock for tests: time moves only when told to.

    ``sleep_until_ns`` jumps to the deadline (plus ``wake_latency_ns``, to model a late
    wake-up) and records the call; ``advance(ns)`` models compute time inside a tick.
    """

    def __init__(self, start_ns: int = 0, wake_latency_ns: int = 0):
        self.t = int(start_ns)
        self.wake_latency_ns = int(wake_latency_ns)
        self.sleeps: list[int] = []  # every deadline asked for, in order

    def now_ns(self) -> int:
        return self.t

    def sleep_until_ns(self, deadline_ns: int) -> None:
        self.sleeps.append(deadline_ns)
        self.t = max(self.t, deadline_ns) + self.wake_latency_ns

    def advance(self, ns: int) -> None:
        self.t += int(ns)
