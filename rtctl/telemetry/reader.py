"""Read a telemetry file back into numpy arrays, one per column, all batches concatenated.

A file whose last record was cut (a crash mid-write) reads back every complete record before
the cut; ``Telemetry.truncated`` says that it happened.
"""
from __future__ import annotations

import os

import msgpack
import numpy as np

from rtctl.errors import TelemetryError
from rtctl.telemetry.schema import FORMAT, VERSION, schema_from_wire

_READ_SIZE = 1 << 20


class Telemetry:
    """A recorded run: ``columns`` (name → array of shape ``(rows, *shape)``), ``header``,
    ``meta`` (the recorder's run metadata), ``footer`` (None if the writer never wrote one),
    ``truncated`` (the file ends inside a record). ``tel["q"]`` is ``tel.columns["q"]``."""

    def __init__(self, path: str, header: dict, columns: dict[str, np.ndarray], footer, truncated: bool):
        self.path = path
        self.header = header
        self.meta = header.get("meta", {})
        self.schema = schema_from_wire(header["schema"])
        self.columns = columns
        self.footer = footer
        self.truncated = truncated

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values())))

    @property
    def dropped_rows(self) -> int:
        return self.footer.get("dropped_rows", 0) if self.footer else 0

    @property
    def incomplete(self) -> str | None:
        """Why the file is not a finished run's (None when it is): for the commands that read
        it to say so, with how many rows they read."""
        if self.truncated:
            return f"the file ends inside a record (a crash while writing): {self.rows} complete rows read"
        if self.footer is None:
            return f"the file has no footer (the run did not finish writing it): {self.rows} rows read"
        return None

    def require_rows(self, what: str, minimum: int = 1) -> None:
        """TelemetryError (exit 2) saying why there is nothing to ``what`` when fewer than
        ``minimum`` rows were recorded — a header alone is what a daemon killed as it started leaves."""
        if self.rows < minimum:
            why = f"; {self.incomplete}" if self.incomplete else ""
            raise TelemetryError(f"{self.path}: nothing to {what}: {self.rows} rows recorded "
                                 f"(at least {minimum} needed){why}")

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def __repr__(self) -> str:
        return (f"Telemetry({self.path!r}, rows={self.rows}, columns={list(self.columns)}, "
                f"footer={'yes' if self.footer else 'no'}, truncated={self.truncated})")


def _check_header(path: str, header) -> None:
    if not isinstance(header, dict) or header.get("type") != "header" or header.get("format") != FORMAT:
        raise TelemetryError(f"{path}: not an rtctl telemetry file (first record is not its header)")
    if header.get("version") != VERSION:
        raise TelemetryError(f"{path}: telemetry format version {header.get('version')!r}, "
                             f"this rtctl reads version {VERSION}")


def read(path) -> Telemetry:
    """Read the telemetry file ``path`` (see :mod:`rtctl.telemetry.schema` for the format)."""
    path = os.fspath(path)
    try:
        f = open(path, "rb")
    except OSError as exc:
        raise TelemetryError(f"cannot open telemetry file {path}: {exc.strerror}") from exc
    with f:
        size = os.fstat(f.fileno()).st_size
        unpacker = msgpack.Unpacker(f, raw=False, read_size=_READ_SIZE, max_buffer_size=0)
        try:
            records = iter(unpacker)
            header = next(records, None)
            if header is None:
                raise TelemetryError(f"{path}: no complete header (empty or truncated file)")
            _check_header(path, header)
            complete_bytes = unpacker.tell()
            schema = schema_from_wire(header["schema"])
            chunks: dict[str, list[bytes]] = {name: [] for name in schema}
            footer = None
            for index, record in enumerate(records, start=1):
                kind = record.get("type") if isinstance(record, dict) else None
                if footer is not None or kind not in ("batch", "footer"):
                    raise TelemetryError(f"{path}: record {index} is unexpected ({kind!r} after "
                                         f"{'the footer' if footer is not None else 'a batch'})")
                complete_bytes = unpacker.tell()
                if kind == "footer":
                    footer = record
                    continue
                _check_batch(path, index, record, schema)
                for name in schema:
                    chunks[name].append(record["columns"][name])
        except (ValueError, msgpack.UnpackException) as exc:
            raise TelemetryError(f"{path}: corrupt telemetry data: {exc}") from exc
        truncated = complete_bytes < size
    columns = {name: np.frombuffer(bytearray().join(parts), dtype=dtype).reshape((-1, *shape))
               for (name, parts), (shape, dtype) in zip(chunks.items(), schema.values())}
    return Telemetry(path, header, columns, footer, truncated)


def _check_batch(path: str, index: int, record: dict, schema) -> None:
    n, columns = record.get("n"), record.get("columns")
    if not isinstance(n, int) or n < 0 or not isinstance(columns, dict):
        raise TelemetryError(f"{path}: batch record {index} is malformed")
    for name, (shape, dtype) in schema.items():
        data = columns.get(name)
        expected = n * int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
        if not isinstance(data, bytes) or len(data) != expected:
            raise TelemetryError(f"{path}: batch record {index}, column {name!r}: expected {expected} bytes "
                                 f"for {n} rows, got {len(data) if isinstance(data, bytes) else type(data).__name__}")
