"""What a hot-path call allocates, for the tests that prove it allocates nothing per tick."""
from __future__ import annotations

import itertools
import sys
import tracemalloc

import pytest


def growth_and_peak(fn, calls: int, warmup: int = 0, repeats: int = 3) -> tuple[int, int]:
    """Bytes still held after ``calls`` calls of ``fn`` (growth), and the most held at once
    during them (peak), both above what was held before; each the smallest of ``repeats``
    measurements. ``warmup`` calls run under tracing first, uncounted (pools that fill once).

    tracemalloc counts every thread's allocations. Under pytest-xdist the worker's channel
    thread receives the next tests while one runs: a message can land in one measurement,
    while an allocation of ``fn`` itself shows in each of them. Under a tracer (coverage, as in
    the mutation runner's unmutated run) the tracer's own records of each line would be
    counted: the measurement is skipped then."""
    if sys.gettrace() is not None:
        pytest.skip("a tracer (coverage) is running: its allocations would be counted as the code's")
    growth = peak = None
    for _ in range(repeats):
        tracemalloc.start()
        try:
            for _ in range(warmup):
                fn()
            times = itertools.repeat(None, calls)  # (made before the count: a loop's iterator is held till its end)
            before, _ = tracemalloc.get_traced_memory()
            tracemalloc.reset_peak()
            for _ in times:
                fn()
            after, top = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        growth = after - before if growth is None else min(growth, after - before)
        peak = top - before if peak is None else min(peak, top - before)
    return growth, peak
