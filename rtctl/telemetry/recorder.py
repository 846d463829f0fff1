"""Recorder: the loop's side of telemetry — one row per tick into preallocated shared blocks.

Design (docs/architecture.md, "Process model": no CPU-bound Python thread in the loop's process). Rows are copied into a
ring of blocks in shared memory; a separate *writer process* (:mod:`rtctl.telemetry.writer`)
serialises full blocks to the file. Serialising in the loop thread at block boundaries was
measured too (``rtctl bench telemetry``): packing a 500-row 6-DoF block is ~0.15 ms and its
``write`` another ~0.1 ms, which fits a 1 ms tick's slack on average, but a ``write`` to a
file can stall for milliseconds when the kernel writes back dirty pages, and that stall would
land inside a tick. With the writer process the loop's cost per tick is fixed: copy the
columns into the staging row, one memcpy of the row into the block, one counter store; once
per block a 1-byte non-blocking pipe write wakes the writer.

Per tick::

    rec.row["t"][()] = t                 # staging row: stable views, one per column
    rec.row["q"][:] = state.position     # ... or bind sources once and call rec.record()
    rec.commit()

When every block still waits for the writer (disk stalled for ``n_blocks`` blocks), the
real-time mode (``wait_when_full=False``) drops the row and counts it (``dropped_rows``, also
in the footer) — it never blocks the tick; the as-fast-as-possible mode
(``wait_when_full=True``) waits for the writer, so nothing is ever dropped there.

Nothing recorded is lost: ``close()`` (call it from the loop after SIGTERM/SIGINT) hands the
partial block over and waits for the writer to write it, the footer and fsync. If the loop
process dies without closing (even SIGKILL), the writer sees its pipe close and still saves
every committed row from shared memory; the footer then says ``clean: False``.
"""
from __future__ import annotations

import fcntl
import os
import stat
import subprocess
import time

import msgpack
import numpy as np

from rtctl.errors import ResourceBusyError, TelemetryError
from rtctl.telemetry.ring import DROPPED, FAILED, READY, RELEASED, STORED, Ring
from rtctl.telemetry.schema import FORMAT, VERSION, normalise_schema, row_dtype, schema_to_wire
from rtctl.telemetry.ring_reader import close_message, spawn_ring_reader

_WAKE = b"F"
_WAIT_POLL_S = 200e-6


def open_exclusive(path: str) -> int:
    """Open ``path`` for writing, lock it (``flock``, advisory, held by the writer process for
    the run) and only then truncate it: a second run given the same file gives up with
    :class:`ResourceBusyError` before it has changed a byte of the first one's."""
    try:  # O_NONBLOCK: a FIFO without a reader fails (ENXIO) instead of blocking the start-up
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_NONBLOCK | os.O_CLOEXEC, 0o644)
    except OSError as exc:
        raise TelemetryError(f"cannot create telemetry file {path}: {exc.strerror}") from exc
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISREG(mode):
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise ResourceBusyError(f"telemetry file {path} is being written by another running rtctl "
                                        "(it holds the file's lock); choose another --telemetry path") from None
            os.ftruncate(fd, 0)
        elif not stat.S_ISCHR(mode):  # a device (/dev/null) is written as it is
            raise TelemetryError(f"telemetry file {path} exists and is neither a regular file nor a device")
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


class Recorder:
    """Record per-tick rows of ``schema`` (``{name: (shape, dtype)}``) into the file ``path``.

    ``meta`` (msgpack-able: config path, rate, robot, ...) goes into the header. Rows are
    kept in ``n_blocks`` shared blocks of ``block_rows`` rows; at 1 kHz the defaults give
    the writer 2 s of slack before the real-time mode starts dropping rows.
    """

    def __init__(self, path, schema, meta=None, *, block_rows: int = 500, n_blocks: int = 4,
                 wait_when_full: bool = False):
        if block_rows < 1 or n_blocks < 2:
            raise TelemetryError(f"need block_rows >= 1 and n_blocks >= 2, got {block_rows}, {n_blocks}")
        self.path = os.fspath(path)
        self.schema = normalise_schema(schema)
        self.block_rows, self.n_blocks = block_rows, n_blocks
        self.wait_when_full = wait_when_full
        self.meta = meta or {}
        self._closed = False
        self._bound: list[tuple[memoryview, memoryview]] = []
        dtype = row_dtype(self.schema)
        self._staging = np.zeros(1, dtype)
        # Views into the staging row, stable for the recorder's life (scalars are 0-d views).
        self.row = {name: self._staging[name][0] if shape else self._staging[name].reshape(())
                    for name, (shape, _) in self.schema.items()}
        self._staging_bytes = memoryview(self._staging.view(np.uint8))
        self._row_bytes = dtype.itemsize
        self._block_bytes = dtype.itemsize * block_rows
        header = {"type": "header", "format": FORMAT, "version": VERSION,
                  "schema": schema_to_wire(self.schema), "block_rows": block_rows,
                  "meta": self.meta, "start_time": time.time()}
        try:
            header_bytes = msgpack.packb(header)
        except (TypeError, ValueError) as exc:
            raise TelemetryError(f"telemetry metadata is not msgpack-serialisable: {exc}") from exc
        file_fd = open_exclusive(self.path)
        try:
            if os.write(file_fd, header_bytes) != len(header_bytes):
                raise OSError("short write")
            self._ring = Ring.create(dtype, block_rows, n_blocks)
            self._proc, self._pipe_fd = self._start_writer(file_fd)
        except OSError as exc:
            raise TelemetryError(f"cannot write telemetry file {self.path}: {exc}") from exc
        finally:
            os.close(file_fd)  # the writer owns the file from here on
        self._ctl = self._ring.ctl
        self._ring_bytes = self._ring.rows
        self._stored = 0
        self._dropped = 0
        self._block_no = 0  # index of the current block in the run (not in the ring)
        self._block_start = 0  # byte offset of the current block in the ring
        self._offset = 0  # byte offset of the next row in the ring

    def _start_writer(self, file_fd: int):
        read_fd, write_fd = os.pipe()
        config = {"schema": schema_to_wire(self.schema), "block_rows": self.block_rows,
                  "n_blocks": self.n_blocks, "ring_fd": self._ring.fd, "file_fd": file_fd, "pipe_fd": read_fd}
        try:
            proc = spawn_ring_reader("rtctl.telemetry.writer", config, (self._ring.fd, file_fd, read_fd))
        except OSError as exc:
            os.close(write_fd)
            raise TelemetryError(f"cannot start the telemetry writer process: {exc}") from exc
        finally:
            os.close(read_fd)
        os.set_blocking(write_fd, False)  # a wake-up must never block the tick
        return proc, write_fd

    def wait_ready(self, timeout_s: float = 30.0) -> None:
        """Return once the writer process is attached to the ring and waiting for rows; a
        writer that exits first, or is not ready within ``timeout_s``, is a TelemetryError."""
        end = time.monotonic() + timeout_s
        while not self._ctl[READY]:
            code = self._proc.poll()
            if code is not None:
                raise TelemetryError(f"the telemetry writer for {self.path} exited ({code}) before it started")
            if time.monotonic() > end:
                raise TelemetryError(f"the telemetry writer for {self.path} did not start within {timeout_s:g} s")
            time.sleep(_WAIT_POLL_S)

    @property
    def ring_fd(self) -> int:
        """The shared ring's fd, for another process that reads the rows (the live view)."""
        return self._ring.fd

    # ---- hot path -------------------------------------------------------------------

    def bind(self, name: str, source: np.ndarray) -> None:
        """Have :meth:`record` copy ``source`` into column ``name``.

        ``source`` is an array the loop updates in place (e.g. ``state.position``): C-contiguous,
        of the column's shape and dtype. The copy is a memoryview slice assignment, ~0.2 µs
        against ~0.35 µs for numpy's ``dst[...] = src``.
        """
        if name not in self.row:
            raise TelemetryError(f"telemetry has no column {name!r}; columns: {', '.join(self.row)}")
        shape, dtype = self.schema[name]
        if (not isinstance(source, np.ndarray) or source.shape != shape or source.dtype != dtype
                or not source.flags.c_contiguous):
            raise TelemetryError(f"telemetry column {name!r} binds a C-contiguous {dtype} array of shape "
                                 f"{shape}, got {type(source).__name__} {getattr(source, 'dtype', '')} "
                                 f"{np.shape(source)}")
        offset = self._staging.dtype.fields[name][1]
        dst = self._staging_bytes[offset:offset + source.nbytes]
        self._bound.append((dst, memoryview(source.reshape(-1)).cast("B")))

    def record(self) -> bool:
        """Copy every bound source into the staging row, then :meth:`commit`."""
        for dst, src in self._bound:
            dst[:] = src
        return self.commit()

    def commit(self) -> bool:
        """Store the staging row as the next row; False if it had to be dropped (see module doc)."""
        offset = self._offset
        if offset == self._block_start and self._block_no - self._ctl[RELEASED] >= self.n_blocks:
            if not (self.wait_when_full and self._wait_for_block()):
                self._dropped += 1
                self._ctl[DROPPED] = self._dropped
                return False
        end = offset + self._row_bytes
        self._ring_bytes[offset:end] = self._staging_bytes  # memoryview copy: ~2x numpy's speed
        self._stored = stored = self._stored + 1
        self._ctl[STORED] = stored  # the row now belongs to the writer, even if this process dies
        if end == self._block_start + self._block_bytes:
            self._next_block()
        else:
            self._offset = end
        return True

    def _next_block(self) -> None:
        self._block_no += 1
        self._offset = self._block_start = (self._block_no % self.n_blocks) * self._block_bytes
        try:
            os.write(self._pipe_fd, _WAKE)
        except (BlockingIOError, BrokenPipeError):
            pass  # pipe full: the writer is awake anyway; gone: close() reports it

    def _wait_for_block(self) -> bool:
        while self._block_no - self._ctl[RELEASED] >= self.n_blocks:
            if self._proc.poll() is not None:
                return False
            time.sleep(_WAIT_POLL_S)
        return True

    # ---- status and shutdown -----------------------------------------------------------

    @property
    def rows(self) -> int:
        """Rows stored so far (every one of them reaches the file)."""
        return self._stored

    @property
    def dropped_rows(self) -> int:
        return self._dropped

    @property
    def writer_alive(self) -> bool:
        return not self._closed and self._proc.poll() is None

    @property
    def failure(self) -> str | None:
        """Why the writer can no longer write (None while it can): one shared-memory read,
        cheap enough to ask every tick."""
        code = self._ctl[FAILED] if self._ctl is not None else 0
        return f"cannot write telemetry file {self.path}: {os.strerror(code)}" if code else None

    def close(self, summary=None, timeout: float = 30.0) -> None:
        """Write the partial block, the footer (with ``summary``) and fsync; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        message = close_message(summary)
        os.set_blocking(self._pipe_fd, True)
        try:
            os.write(self._pipe_fd, message)
        except BrokenPipeError:
            pass  # reported below from the writer's exit status
        finally:
            os.close(self._pipe_fd)
        try:
            code = self._proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
            code = None
        failure = self.failure
        self._ctl = self._ring_bytes = None
        self._ring.close()
        if code != 0:
            why = failure or f"telemetry writer for {self.path} failed"
            raise TelemetryError(f"{why} ({'timed out' if code is None else f'exit status {code}'}); "
                                 f"rows stored: {self._stored}")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
