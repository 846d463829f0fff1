"""The telemetry writer process: serialises full blocks of the shared ring to the file.

Started by :class:`rtctl.telemetry.Recorder` as ``python -m rtctl.telemetry.writer CONFIG``
with three inherited fds: the shared ring, the open telemetry file and the read end of a
pipe. The loop writes one byte ``F`` into the pipe when a block fills (a wake-up only: the
ring's counters are the truth) and ``C`` + 4-byte big-endian length + msgpack summary when
it closes. The writer

* ignores SIGINT and SIGTERM from birth (a Ctrl-C or systemd's SIGTERM reaches the whole process
  group; the writer must outlive the loop's shutdown to save its last rows), drops any
  real-time scheduling inherited from the loop and lowers its priority;
* on ``C`` or on end-of-file (the loop process died, even by SIGKILL) writes every stored
  row, including the partial block, then the footer, fsyncs and exits;
* when a write fails (a full disk: ENOSPC) stores the errno in the ring's ``FAILED`` counter
  at once and exits with status 3: the loop reports it and applies its policy.

Each batch goes to the kernel with one ``write`` as soon as it is packed, so a crash of
either process loses at most the rows of the batch being written.
"""
from __future__ import annotations

import errno
import json
import os
import sys
import time

import msgpack

from rtctl.telemetry.ring import DROPPED, FAILED, READY, RELEASED, STORED, Ring
from rtctl.telemetry.ring_reader import detach_from_loop, read_summary
from rtctl.telemetry.schema import row_dtype, schema_from_wire


EXIT_WRITE_FAILED = 3


def pack_batch(block, n: int) -> bytes:
    """One batch record: each column of the first ``n`` rows as C-order bytes."""
    return msgpack.packb({"type": "batch", "n": n,
                          "columns": {name: block[name][:n].tobytes() for name in block.dtype.names}})


class Writer:
    def __init__(self, ring: Ring, file_fd: int, pipe_fd: int):
        self.ring, self.file_fd, self.pipe_fd = ring, file_fd, pipe_fd
        self.released = 0

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.file_fd, view):]

    def flush_full_blocks(self) -> None:
        ring = self.ring
        while self.released < ring.ctl[STORED] // ring.block_rows:
            block = ring.blocks[self.released % ring.n_blocks]
            self._write(pack_batch(block, ring.block_rows))
            self.released += 1
            ring.ctl[RELEASED] = self.released  # only now may the loop reuse the block

    def finish(self, summary, clean: bool) -> None:
        ring = self.ring
        self.flush_full_blocks()
        stored = ring.ctl[STORED]
        partial = stored % ring.block_rows
        if partial:
            self._write(pack_batch(ring.blocks[self.released % ring.n_blocks], partial))
        self._write(msgpack.packb({"type": "footer", "rows": stored, "dropped_rows": ring.ctl[DROPPED],
                                   "clean": clean, "end_time": time.time(), "summary": summary}))
        os.fsync(self.file_fd)
        os.close(self.file_fd)

    def run(self) -> None:
        pending = b""
        while True:
            chunk = os.read(self.pipe_fd, 65536)  # blocks: the loop's wake-up or its exit
            if not chunk:  # the loop process is gone without closing: save what it stored
                self.finish(None, clean=False)
                return
            pending += chunk
            self.flush_full_blocks()
            start = pending.find(b"C")
            if start >= 0:
                summary = read_summary(self.pipe_fd, pending[start + 1:])
                self.finish(summary, clean=True)
                return
            pending = b""


def main(argv=None) -> int:
    config = json.loads((argv or sys.argv[1:])[0])
    detach_from_loop()
    schema = schema_from_wire(config["schema"])
    ring = Ring(config["ring_fd"], row_dtype(schema), config["block_rows"], config["n_blocks"])
    writer = Writer(ring, config["file_fd"], config["pipe_fd"])
    ring.ctl[READY] = 1
    try:
        writer.run()
    except OSError as e:
        ring.ctl[FAILED] = e.errno or errno.EIO
        print(f"rtctl telemetry writer: {e}", file=sys.stderr)
        return EXIT_WRITE_FAILED
    return 0


if __name__ == "__main__":
    sys.exit(main())
