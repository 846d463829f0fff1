"""Logging: structlog, JSON lines on stdout (systemd/journald-friendly) for the daemon,
plain key=value on stderr for interactive commands."""
from __future__ import annotations

import logging
import sys

import structlog


def configure(json: bool = True, level: str = "info", stream=None) -> None:
    stream = stream or (sys.stdout if json else sys.stderr)
    renderer = structlog.processors.JSONRenderer() if json else structlog.dev.ConsoleRenderer(colors=False)
    structlog.configure(
        processors=[
            structlog.processors.add_log_level,
            structlog.processors.TimeStamper(fmt="iso", utc=True),
            structlog.processors.format_exc_info,
            renderer,
        ],
        wrapper_class=structlog.make_filtering_bound_logger(getattr(logging, level.upper())),
        logger_factory=structlog.PrintLoggerFactory(stream),
        cache_logger_on_first_use=False,
    )
