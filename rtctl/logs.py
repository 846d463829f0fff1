"""Logging: structlog, in one of two formats.

* ``json``: one strict JSON object per line (no NaN/Infinity, see :mod:`rtctl.jsonout`) —
  for systemd/journald, log shippers and scripts; the default when stdout is not a terminal;
* ``console``: structlog's human-readable renderer (time, level, event, key=value) — the
  default on a terminal.

``--log-format auto|console|json`` chooses (:func:`resolve_format`).
"""
from __future__ import annotations

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
