"""Benchmarks that `rtctl bench …` runs on the user's machine: each returns a JSON-able dict and has a
``format_table``; timing goals live here, never in tests."""

import time

import numpy as np


def compiled_us(loop, args, count: int = 2000) -> float:
    """Median µs per call of a kernel inside ``loop(count, *args)`` (a numba loop calling it
    ``count`` times: the arithmetic with no call from Python), over 7 runs after a warm-up."""
    loop(1, *args)
    samples = []
    for _ in range(7):
        t0 = time.perf_counter_ns()
        loop(count, *args)
        samples.append((time.perf_counter_ns() - t0) / count / 1e3)
    return float(np.median(samples))


def median_us(fn, repeats: int, batch: int) -> float:
    """Median µs per call of ``fn`` over batches of ``batch`` calls, after a warm-up batch."""
    for _ in range(batch):
        fn()
    samples = []
    for _ in range(max(1, repeats // batch)):
        t0 = time.perf_counter_ns()
        for _ in range(batch):
            fn()
        samples.append((time.perf_counter_ns() - t0) / batch / 1e3)
    return float(np.median(samples))


def percentiles_us(ns) -> dict:
    """p50 / p99 / p99.9 / max of durations in ns, as µs (the benches' common row)."""
    us = np.asarray(ns) / 1e3
    return {"p50_us": float(np.percentile(us, 50)), "p99_us": float(np.percentile(us, 99)),
            "p99_9_us": float(np.percentile(us, 99.9)), "max_us": float(us.max())}
