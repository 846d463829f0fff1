"""What the processes that read the telemetry ring beside the loop share (the writer, the
live view): how they are started and detached from the loop, and the loop's closing message."""
from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import sys

import msgpack


def spawn_ring_reader(module: str, config: dict, pass_fds: tuple[int, ...]) -> subprocess.Popen:
    """Start ``python -m module CONFIG-JSON`` with the inherited ``pass_fds``: a process that reads
    the ring beside the loop (the writer, the live view).

    It must ignore SIGTERM/SIGINT from birth: a signal to the process group while it still
    imports would kill it. A blocked mask survives exec (a handler does not); the process
    then ignores both and unblocks (:func:`detach_from_loop`). The
    loop's own copies of those signals stay pending during Popen, they are not lost."""
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        return subprocess.Popen([sys.executable, "-m", module, json.dumps(config)], pass_fds=pass_fds,
                                stdin=subprocess.DEVNULL)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def close_message(summary) -> bytes:
    """What the loop sends a ring reader when the run ends: ``C`` + 4-byte big-endian length +
    the msgpack summary (or why it could not be packed)."""
    try:
        payload = msgpack.packb(summary)
    except (TypeError, ValueError) as exc:  # the rows matter more than the summary
        payload = msgpack.packb({"error": f"summary not msgpack-serialisable: {exc}"})
    return b"C" + struct.pack(">I", len(payload)) + payload


def read_summary(pipe_fd: int, data: bytes):
    """The run's summary after the close byte ``C``: 4-byte big-endian length + msgpack; the
    rest of it is read from ``pipe_fd``. None if the pipe closed before the end of it."""
    while len(data) < 4 or len(data) < 4 + struct.unpack(">I", data[:4])[0]:
        chunk = os.read(pipe_fd, 65536)
        if not chunk:
            return None  # closed mid-message: the rows matter more than the summary
        data += chunk
    (length,) = struct.unpack(">I", data[:4])
    return msgpack.unpackb(data[4:4 + length])


def detach_from_loop() -> None:
    """Outlive the loop's shutdown and never compete with it: ignore SIGINT/SIGTERM, drop a
    real-time scheduling inherited from the loop, lower the priority."""
    # Both arrive blocked (see recorder.spawn_ring_reader); ignoring discards any pending one.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    if hasattr(os, "sched_setscheduler"):
        try:  # SCHED_FIFO is inherited unless reset; the writer must never preempt the loop
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        except OSError:
            pass
    os.nice(10)
