"""Which compiled kernels a run calls from Python, how often, and what they cost alone.

:class:`KernelCensus` replaces every numba dispatcher reachable as a module global of rtctl,
hil_sim or drivers by a counting wrapper that also keeps a copy of the last arguments it saw.
After a run under the census, :meth:`KernelCensus.cost_per_tick` calls each kernel directly on
copies of the inputs it had at a few spread-out calls (reset before every call, so a plant
step or an adaptation law does not drift) and sums ``calls per tick × median µs per call``: the compiled
floor under the tick — what it would cost with no Python between the kernels. Kernels called
by other kernels are part of their caller's time; numpy's own functions are not counted.
Enter it only after the run's kernels are compiled (a first run): a kernel compiled while the
census is in place would see a wrapper where its callee should be, and not compile.
"""
from __future__ import annotations

import sys
import time

import numpy as np
from numba.core.registry import CPUDispatcher

PACKAGES = ("rtctl", "hil_sim", "drivers")


def _copy(value):
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, tuple):
        return tuple(_copy(v) for v in value)
    return value


def _restore(work, saved) -> None:
    for w, s in zip(work, saved):
        if isinstance(w, np.ndarray):
            np.copyto(w, s)
        elif isinstance(w, tuple):
            _restore(w, s)


SNAPSHOT_EVERY = 97  # calls between two copies of a kernel's inputs (prime: no lock-step with a divisor)
SNAPSHOTS = 8


class _Counted:
    __slots__ = ("kernel", "calls", "args", "snapshots")

    def __init__(self, kernel):
        self.kernel, self.calls, self.args, self.snapshots = kernel, 0, None, []

    def __call__(self, *args):  # the kernels are called positionally
        self.calls += 1
        self.args = args  # copied once, at the end of the run (a copy per call would be the run's cost)
        if self.calls % SNAPSHOT_EVERY == 0 and len(self.snapshots) < SNAPSHOTS:
            self.snapshots.append(_copy(args))  # its inputs as the run gave them, at spread-out calls
        return self.kernel(*args)


def _timer_overhead_ns() -> float:
    """Median of two back-to-back perf_counter_ns reads."""
    deltas = []
    for _ in range(1000):
        t0 = time.perf_counter_ns()
        deltas.append(time.perf_counter_ns() - t0)
    return float(np.median(deltas))


class KernelCensus:
    def __init__(self):
        self._patched: list[tuple[object, str, CPUDispatcher]] = []
        self.counted: dict[int, _Counted] = {}

    def __enter__(self) -> "KernelCensus":
        for name, module in list(sys.modules.items()):
            if module is None or name.split(".")[0] not in PACKAGES:
                continue
            for attr, value in list(vars(module).items()):
                if isinstance(value, CPUDispatcher):
                    counted = self.counted.setdefault(id(value), _Counted(value))
                    setattr(module, attr, counted)
                    self._patched.append((module, attr, value))
        return self

    def __exit__(self, *exc) -> None:
        for module, attr, value in self._patched:
            setattr(module, attr, value)
        self._patched.clear()
        for c in self.counted.values():  # arguments as they stood after the last call: a tick's arrays
            c.args = None if c.args is None else _copy(c.args)

    def cost_per_tick(self, ticks: int, samples: int = 400) -> dict:
        """{"kernels": {name: {"calls_per_tick", "us_per_call", "us_per_tick"}}, "total_us"} for the
        kernels called at least once every 100 ticks (fewer calls are start-up and warm-up).

        Each call is timed alone on the inputs the run gave it at one of up to ``SNAPSHOTS``
        spread-out calls (restored before every call: an adaptation law repeated on its own output
        drifts somewhere the run never goes); the median over all of them, less the timer's own
        cost, is the kernel's µs per call."""
        rows, total = {}, 0.0
        timer = _timer_overhead_ns()
        for c in self.counted.values():
            per_tick = c.calls / max(ticks, 1)
            if c.args is None or c.calls * 100 < ticks:
                continue
            inputs = c.snapshots or [_copy(c.args)]
            work = [_copy(a) for a in inputs]
            fn = c.kernel
            fn(*work[0])
            times = []
            for k in range(samples):
                args, saved = work[k % len(work)], inputs[k % len(work)]
                _restore(args, saved)
                t0 = time.perf_counter_ns()
                fn(*args)
                times.append(time.perf_counter_ns() - t0 - timer)
            us = max(float(np.median(times)), 0.0) / 1e3
            rows[fn.py_func.__qualname__] = {"calls_per_tick": per_tick, "us_per_call": us,
                                             "us_per_tick": per_tick * us}
            total += per_tick * us
        return {"kernels": dict(sorted(rows.items(), key=lambda kv: -kv[1]["us_per_tick"])), "total_us": total}
