"""A stand-in for the daemon's loop: records one row per tick until SIGTERM/SIGINT, then closes.

Usage: record_until_signal.py PATH MODE where MODE is ``paced`` (1 kHz on absolute deadlines,
real-time recorder that drops rather than waits) or ``fast`` (no pacing, recorder waits for
the writer, like ``realtime_factor = 0``). Prints ``ready``, then ``stored N`` after every
block, then ``recorded N dropped D`` after closing. Row k holds t = k and q = k + joint index.
"""
import signal
import sys
import time

import numpy as np

from rtctl.telemetry import Recorder

SCHEMA = {"t": ((), "f8"), "q": ((6,), "f8"), "tau": ((6,), "f8"), "phase_ns": ((5,), "i8"), "tick": ((), "i8")}
stop = False


def on_signal(signum, frame):
    global stop
    stop = True  # like the daemon: the loop notices at the next tick boundary


def main():
    path, mode = sys.argv[1], sys.argv[2]
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    rec = Recorder(path, SCHEMA, {"mode": mode}, block_rows=250, n_blocks=4, wait_when_full=(mode == "fast"))
    q = np.zeros(6)
    rec.bind("q", q)
    t_row, tick_row = rec.row["t"], rec.row["tick"]
    period = 1e-3
    deadline = time.monotonic()
    print("ready", flush=True)
    k = 0
    while not stop:
        q[:] = np.arange(6) + k
        t_row[()] = k
        tick_row[()] = k
        rec.record()
        k += 1
        if k % 250 == 0:
            print(f"stored {rec.rows}", flush=True)
        if mode == "paced":
            deadline += period
            time.sleep(max(0.0, deadline - time.monotonic()))
    rec.close(summary={"ticks": k})
    print(f"recorded {k} dropped {rec.dropped_rows}", flush=True)


if __name__ == "__main__":
    main()
