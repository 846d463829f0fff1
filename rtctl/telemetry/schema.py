"""Telemetry file format: the column schema and the three kinds of record.

A telemetry file is a plain concatenation of msgpack maps, one per record:

* ``header`` (exactly one, first): ``{"type": "header", "format": "rtctl-telemetry",
  "version": 1, "schema": {name: {"shape": [...], "dtype": "<f8"}}, "block_rows": B,
  "meta": {...run metadata...}, "start_time": unix seconds}``;
* ``batch`` (any number): ``{"type": "batch", "n": n_rows, "columns": {name: bytes}}`` where
  each value is the C-order bytes of an ``(n_rows, *shape)`` array of the column's dtype;
* ``footer`` (optional, last): ``{"type": "footer", "rows": stored, "dropped_rows": d,
  "clean": bool, "end_time": unix seconds, "summary": {...} | None}``.

msgpack is self-delimiting, so a file cut anywhere still parses up to the last complete
record; that is what makes a crash mid-write lose only the record being written.
"""
from __future__ import annotations

import numpy as np

from rtctl.errors import TelemetryError

FORMAT = "rtctl-telemetry"
VERSION = 1

Schema = dict[str, tuple[tuple[int, ...], np.dtype]]


def normalise_schema(schema) -> Schema:
    """``{name: (shape, dtype)}`` with shape an int or a tuple (``()`` for scalars)."""
    if not schema:
        raise TelemetryError("telemetry schema is empty: give at least one column")
    out: Schema = {}
    for name, spec in schema.items():
        if not isinstance(name, str) or not name:
            raise TelemetryError(f"telemetry column name must be a non-empty string, got {name!r}")
        try:
            shape, dtype = spec
            shape = (shape,) if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
            dtype = np.dtype(dtype)
        except (TypeError, ValueError) as exc:
            raise TelemetryError(f"telemetry column {name!r}: expected (shape, dtype), got {spec!r}") from exc
        if any(s < 1 for s in shape):
            raise TelemetryError(f"telemetry column {name!r}: every dimension must be >= 1, got {shape}")
        if dtype.kind not in "biufc":
            raise TelemetryError(f"telemetry column {name!r}: dtype must be numeric or bool, got {dtype}")
        out[name] = (shape, dtype)
    return out


def row_dtype(schema: Schema) -> np.dtype:
    """One record holding a whole row: the staging row and the shared blocks use it."""
    return np.dtype([(name, dtype, shape) for name, (shape, dtype) in schema.items()], align=True)


def schema_to_wire(schema: Schema) -> dict:
    return {name: {"shape": list(shape), "dtype": dtype.str} for name, (shape, dtype) in schema.items()}


def schema_from_wire(wire) -> Schema:
    try:
        return normalise_schema({name: (tuple(c["shape"]), c["dtype"]) for name, c in wire.items()})
    except (AttributeError, KeyError, TypeError) as exc:
        raise TelemetryError(f"telemetry header has a malformed schema: {wire!r}") from exc
