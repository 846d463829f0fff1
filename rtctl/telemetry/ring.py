"""The ring of row blocks shared by the loop process and the telemetry writer process.

Layout of the shared mapping (an anonymous ``memfd``, inherited by the writer as an fd):
a 64-byte control area of int64 counters, then ``n_blocks`` blocks of ``block_rows`` rows of
the row dtype. Counters, each written by one side only:

* ``STORED`` (loop): rows stored so far. Row ``k`` of the run lives in block
  ``(k // B) % n_blocks`` at row ``k % B``; blocks ``< STORED // B`` are full.
* ``DROPPED`` (loop): rows the loop could not store because every block was still waiting
  for the writer (real-time mode never waits; see :class:`~rtctl.telemetry.Recorder`).
* ``RELEASED`` (writer): full blocks written to the file; their memory may be reused.
* ``FAILED`` (writer): 0 while it writes; the errno of the write that failed (ENOSPC, EIO …)
  once it cannot write any more, so the loop learns of it within a tick.
* ``READY`` (writer): 1 once it is attached and waiting for blocks; the loop starts only then
  (a writer still starting would stall a lock-step run within its first few thousand rows).

One monotonic counter per side (rather than "block full" flags) means a loop process that
dies between any two statements leaves a consistent state: the writer can still save every
row counted in ``STORED``.
"""
from __future__ import annotations

import mmap
import os
import tempfile

import numpy as np

STORED, DROPPED, RELEASED, FAILED, READY = 0, 1, 2, 3, 4
CTL_BYTES = 64


class Ring:
    """Views over the shared mapping; memoryviews where the loop writes (cheaper than numpy per call)."""

    def __init__(self, fd: int, row_dtype: np.dtype, block_rows: int, n_blocks: int):
        self.fd = fd
        self.block_rows = block_rows
        self.n_blocks = n_blocks
        self.map = mmap.mmap(fd, self.size(row_dtype, block_rows, n_blocks))
        self.ctl = memoryview(self.map)[:CTL_BYTES].cast("q")
        self.rows = memoryview(self.map)[CTL_BYTES:]  # raw bytes of all blocks: the loop's memcpy target
        rows = np.frombuffer(self.map, dtype=row_dtype, count=block_rows * n_blocks, offset=CTL_BYTES)
        self.blocks = [rows[k * block_rows:(k + 1) * block_rows] for k in range(n_blocks)]

    @staticmethod
    def size(row_dtype: np.dtype, block_rows: int, n_blocks: int) -> int:
        return CTL_BYTES + row_dtype.itemsize * block_rows * n_blocks

    @classmethod
    def create(cls, row_dtype: np.dtype, block_rows: int, n_blocks: int) -> "Ring":
        """A fresh zeroed mapping backed by an fd the writer process can inherit."""
        if hasattr(os, "memfd_create"):
            fd = os.memfd_create("rtctl-telemetry")
        else:  # not Linux: an unlinked temporary file serves the same purpose
            fd = os.dup(tempfile.TemporaryFile().fileno())
        os.ftruncate(fd, cls.size(row_dtype, block_rows, n_blocks))
        ring = cls(fd, row_dtype, block_rows, n_blocks)
        ring.rows[:] = bytes(len(ring.rows))  # fault every page in now, not one per few ticks later
        return ring

    def close(self) -> None:
        self.blocks = None
        self.ctl.release()
        self.rows.release()
        try:
            self.map.close()
        except BufferError:  # a caller still holds a view; the mapping goes with the process
            pass
        os.close(self.fd)
