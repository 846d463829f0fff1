"""Logging: structlog, in one of two formats.

* ``json``: one strict JSON object per line (no NaN/Infinity, see :mod:`rtctl.jsonout`) —
  for systemd/journald, log shippers and scripts; the default when stdout is not a terminal;
* ``console``: structlog's human-readable renderer (time, level, event, key=value) — the
  default on a terminal.

``--log-format auto|console|json`` chooses (:func:`resolve_format`).
"""
from __future__ import annotations

import contextlib
import logging
import sys

import structlog

from rtctl import jsonout

FORMATS = ("auto", "console", "json")


def resolve_format(choice: str, stream=None) -> str:
    """``auto`` → ``console`` on a terminal, ``json`` otherwise."""
    if choice != "auto":
        return choice
    stream = stream or sys.stdout
    isatty = getattr(stream, "isatty", None)
    return "console" if isatty is not None and isatty() else "json"


def configure(fmt: str = "json", level: str = "info", stream=None) -> None:
    stream = stream or sys.stdout
    if fmt == "json":
        stamp = structlog.processors.TimeStamper(fmt="iso", utc=True)
        renderer = structlog.processors.JSONRenderer(serializer=jsonout.dumps)
    elif fmt == "console":
        stamp = structlog.processors.TimeStamper(fmt="%H:%M:%S.%f", utc=False)
        renderer = structlog.dev.ConsoleRenderer(colors=_colors(stream))
    else:
        raise ValueError(f"log format must be 'json' or 'console', not {fmt!r}")
    structlog.configure(
        processors=[
            structlog.processors.add_log_level,
            stamp,
            structlog.processors.format_exc_info,
            *([_short_floats] if fmt == "console" else []),
            renderer,
        ],
        wrapper_class=structlog.make_filtering_bound_logger(getattr(logging, level.upper())),
        logger_factory=structlog.PrintLoggerFactory(stream),
        cache_logger_on_first_use=False,
    )


def _short_floats(logger, method, event: dict) -> dict:
    """Console only: 6 significant digits (t=0.999, not 0.9990000000000001)."""
    return {k: float(f"{v:.6g}") if isinstance(v, float) else v for k, v in event.items()}


def _colors(stream) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty is not None and isatty())


class BackgroundStream:
    """A text stream whose writes never wait: lines are queued and a writer thread (I/O only,
    no computation) hands them to ``target``. For the loop's process, where a reader that does
    not keep up (a full pipe, a slow journald) must not stall a tick. Past ``max_bytes`` queued,
    lines are dropped and counted, and the count is written once the writer catches up.
    :meth:`close` writes what is queued (waiting at most ``timeout`` s) and stops the thread."""

    def __init__(self, target, max_bytes: int = 1 << 20):
        import threading

        self.target, self.max_bytes = target, max_bytes
        self._lines: list[str] = []
        self._queued = self.dropped = 0
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._closing = False
        self._thread = threading.Thread(target=self._drain, name="rtctl-log-writer", daemon=True)
        self._thread.start()

    def write(self, text: str) -> int:
        with self._lock:
            if self._queued + len(text) > self.max_bytes:
                self.dropped += text.count("\n") or 1
            else:
                self._lines.append(text)
                self._queued += len(text)
        return len(text)

    def flush(self) -> None:
        self._wake.set()

    def isatty(self) -> bool:
        return self.target.isatty()

    def close(self, timeout: float = 2.0) -> None:
        self._closing = True
        self._wake.set()
        self._thread.join(timeout)

    def _drain(self) -> None:
        while True:
            self._wake.wait()
            self._wake.clear()
            with self._lock:
                lines, self._lines, self._queued = self._lines, [], 0
                dropped, self.dropped = self.dropped, 0
            try:
                if lines:
                    self.target.write("".join(lines))
                if dropped:
                    self.target.write(f"rtctl: {dropped} log line(s) dropped: the log's reader did not keep up\n")
                self.target.flush()
            except (OSError, ValueError):  # a closed or broken stream: nothing more can be said on it
                pass
            if self._closing and not self._lines:
                return


@contextlib.contextmanager
def written_in_background():
    """While in the block, the log goes through a :class:`BackgroundStream` to where it went
    (``rtctl run``: the loop never waits for its log's reader); on leaving, what is queued is
    written and the direct output restored."""
    factory = structlog.get_config()["logger_factory"]
    stream = BackgroundStream(getattr(factory, "_file", None) or sys.stdout)
    structlog.configure(logger_factory=structlog.PrintLoggerFactory(stream))
    try:
        yield stream
    finally:
        structlog.configure(logger_factory=factory)
        stream.close()
