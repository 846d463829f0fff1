"""``rtctl bench telemetry``: what recording costs the loop, and what the writer process saves it.

* per tick at a paced rate (default 1 kHz) with a 6-DoF schema plus controller internals:
  the column copies (``record()`` over bound sources), the ``commit()`` alone, and both;
* packing one block into a batch record and ``write``-ing it — the cost the loop would pay
  at every block boundary if it serialised in its own thread (the rejected design);
* rows per second in the as-fast-as-possible mode (``wait_when_full=True``).
"""
from __future__ import annotations

import os
import tempfile
import time

import numpy as np

from rtctl.bench import percentiles_us
from rtctl.telemetry import Recorder
from rtctl.telemetry.schema import normalise_schema, row_dtype
from rtctl.telemetry.writer import pack_batch


def six_dof_schema(n_params: int = 60) -> dict:
    vec = ((6,), np.float64)
    return {"t": ((), np.float64), "q": vec, "qd": vec, "q_des": vec, "qd_des": vec, "tau": vec,
            "phase_ns": ((5,), np.int64), "s": vec, "params_hat": ((n_params,), np.float64)}


def _paced_ticks(directory: str, rate: float, seconds: float, block_rows: int) -> dict:
    schema = six_dof_schema()
    n = int(rate * seconds)
    copy_ns, commit_ns = np.zeros(n, np.int64), np.zeros(n, np.int64)
    rec = Recorder(os.path.join(directory, "paced.rtt"), schema, block_rows=block_rows)
    sources = {name: np.random.default_rng(0).standard_normal(shape).astype(dtype)
               for name, (shape, dtype) in normalise_schema(schema).items() if shape}
    for name, src in sources.items():
        rec.bind(name, src)
    t_row = rec.row["t"]
    clock = time.perf_counter_ns
    period = 1.0 / rate
    deadline = time.monotonic()
    for k in range(n):
        a = clock()
        t_row[()] = k * period
        for dst, src in rec._bound:  # what record() does, timed apart from commit()
            dst[:] = src
        b = clock()
        rec.commit()
        c = clock()
        copy_ns[k], commit_ns[k] = b - a, c - b
        deadline += period
        time.sleep(max(0.0, deadline - time.monotonic()))
    rec.close()
    return {"rows": n, "dropped": rec.dropped_rows, "columns": len(schema),
            "row_bytes": row_dtype(normalise_schema(schema)).itemsize,
            "copy": percentiles_us(copy_ns), "commit": percentiles_us(commit_ns),
            "record_total": percentiles_us(copy_ns + commit_ns)}


def _hot_loop(directory: str, rows: int) -> dict:
    """The same per-row work back to back (warm caches): the floor under the paced numbers."""
    rec = Recorder(os.path.join(directory, "hot.rtt"), six_dof_schema(), block_rows=1000,
                   n_blocks=rows // 1000 + 2)
    for name, (shape, dtype) in normalise_schema(six_dof_schema()).items():
        if shape:
            rec.bind(name, np.ones(shape, dtype))
    a = time.perf_counter_ns()
    for _ in range(rows):
        rec.commit()
    b = time.perf_counter_ns()
    for _ in range(rows):
        rec.record()
    c = time.perf_counter_ns()
    rec.close()
    return {"rows": rows, "commit_us": (b - a) / rows / 1e3, "record_us": (c - b) / rows / 1e3}


def _pack_block(directory: str, block_rows: int, repeats: int) -> dict:
    dtype = row_dtype(normalise_schema(six_dof_schema()))
    block = np.zeros(block_rows, dtype)
    block.view(np.uint8)[:] = np.random.default_rng(1).integers(0, 255, block.nbytes, dtype=np.uint8)
    pack_ns, write_ns = np.zeros(repeats, np.int64), np.zeros(repeats, np.int64)
    fd = os.open(os.path.join(directory, "pack.bin"), os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    try:
        for k in range(repeats):
            a = time.perf_counter_ns()
            data = pack_batch(block, block_rows)
            b = time.perf_counter_ns()
            os.write(fd, data)
            c = time.perf_counter_ns()
            pack_ns[k], write_ns[k] = b - a, c - b
    finally:
        os.close(fd)
    return {"block_rows": block_rows, "batch_bytes": len(data), "pack": percentiles_us(pack_ns),
            "write": percentiles_us(write_ns), "pack_and_write": percentiles_us(pack_ns + write_ns)}


def _throughput(directory: str, rows: int, block_rows: int) -> dict:
    rec = Recorder(os.path.join(directory, "fast.rtt"), six_dof_schema(), block_rows=block_rows,
                   wait_when_full=True)
    q = rec.row["q"]
    start = time.perf_counter()
    for k in range(rows):
        q[0] = k
        rec.commit()
    recorded = time.perf_counter() - start
    rec.close()
    return {"rows": rows, "rows_per_s": rows / recorded, "close_s": time.perf_counter() - start - recorded}


def bench_telemetry(rate: float = 1000.0, seconds: float = 5.0, block_rows: int = 500) -> dict:
    with tempfile.TemporaryDirectory(prefix="rtctl-bench-") as directory:
        return {"rate_hz": rate, "seconds": seconds,
                "paced": _paced_ticks(directory, rate, seconds, block_rows),
                "hot": _hot_loop(directory, rows=20_000),
                "block": _pack_block(directory, block_rows, repeats=200),
                "fast": _throughput(directory, rows=200_000, block_rows=block_rows)}


def format_table(result: dict) -> str:
    paced, block, fast, hot = (result[k] for k in ("paced", "block", "fast", "hot"))
    lines = [f"telemetry, 6-DoF schema ({paced['columns']} columns, {paced['row_bytes']} B/row), "
             f"{result['rate_hz']:g} Hz for {result['seconds']:g} s, {paced['dropped']} rows dropped",
             f"{'µs':<34}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}"]

    def row(label, p):
        lines.append(f"{label:<34}{p['p50_us']:>8.2f}{p['p99_us']:>8.2f}{p['p99_9_us']:>8.2f}{p['max_us']:>9.1f}")

    row("per tick: column copies", paced["copy"])
    row("per tick: commit()", paced["commit"])
    row("per tick: total", paced["record_total"])
    lines.append(f"{'back to back (warm): commit()':<34}{hot['commit_us']:>8.2f}   "
                 f"record() = copies + commit: {hot['record_us']:.2f}")
    row(f"pack one {block['block_rows']}-row block", block["pack"])
    row("write() one batch", block["write"])
    row("pack + write (in-loop design)", block["pack_and_write"])
    lines.append(f"as fast as possible: {fast['rows_per_s']:,.0f} rows/s "
                 f"({fast['rows']} rows, close {fast['close_s'] * 1e3:.0f} ms)")
    return "\n".join(lines)
