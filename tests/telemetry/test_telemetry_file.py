"""Recorder → file → read(): round trips, partial blocks, drops, truncated files."""
import os
import signal

import msgpack
import numpy as np
import pytest

from rtctl.errors import TelemetryError
from rtctl.telemetry import Recorder, read

SCHEMA = {
    "t": ((), np.float64),
    "q": ((6,), np.float64),
    "phase_ns": ((5,), np.int64),
    "flags": ((3,), np.bool_),
    "small": ((2, 3), np.float32),
    "count": ((), np.int32),
    "params_hat": ((60,), "<f8"),
}


def random_rows(rng, n):
    def draw(shape, dtype):
        dtype = np.dtype(dtype)
        if dtype.kind == "f":
            return rng.standard_normal((n, *shape)).astype(dtype) * 1e3
        if dtype.kind == "b":
            return rng.integers(0, 2, (n, *shape)).astype(bool)
        info = np.iinfo(dtype)
        return rng.integers(info.min, info.max, (n, *shape), dtype=dtype, endpoint=True)
    return {name: draw(shape, dtype) for name, (shape, dtype) in SCHEMA.items()}


def record(path, data, n, **kwargs):
    kwargs.setdefault("wait_when_full", True)
    rec = Recorder(path, SCHEMA, {"config": "configs/x.toml", "rate_hz": 1000}, **kwargs)
    for k in range(n):
        for name, values in data.items():
            rec.row[name][...] = values[k]
        assert rec.commit()
    rec.close(summary={"ticks": n})
    return rec


@pytest.mark.parametrize("n", [0, 1, 49, 50, 51, 437])
def test_round_trip_random_data(tmp_path, n):
    rng = np.random.default_rng(n)
    data = random_rows(rng, n)
    record(tmp_path / "run.rtt", data, n, block_rows=50, n_blocks=3)
    tel = read(tmp_path / "run.rtt")
    assert tel.rows == n and not tel.truncated
    for name, (shape, dtype) in SCHEMA.items():
        assert tel[name].dtype == np.dtype(dtype) and tel[name].shape == (n, *shape)
        np.testing.assert_array_equal(tel[name], data[name])
    assert tel.meta == {"config": "configs/x.toml", "rate_hz": 1000}
    assert tel.footer["summary"] == {"ticks": n} and tel.footer["clean"] is True
    assert tel.footer["rows"] == n and tel.dropped_rows == 0


def test_partial_last_block_is_written_on_close(tmp_path):
    data = random_rows(np.random.default_rng(1), 130)
    record(tmp_path / "run.rtt", data, 130, block_rows=100, n_blocks=2)
    batches = [r for r in msgpack.Unpacker(open(tmp_path / "run.rtt", "rb")) if r["type"] == "batch"]
    assert [b["n"] for b in batches] == [100, 30]
    np.testing.assert_array_equal(read(tmp_path / "run.rtt")["q"], data["q"])


def test_bound_sources_are_copied_by_record(tmp_path):
    schema = {"t": ((), "f8"), "q": (3, "f8"), "n": ((), "i4"), "m": ((2, 2), "i2")}
    rec = Recorder(tmp_path / "run.rtt", schema, wait_when_full=True)
    q, n, m = np.zeros(3), np.zeros((), np.int32), np.zeros((2, 2), np.int16)
    rec.bind("q", q)
    rec.bind("n", n)
    rec.bind("m", m)
    for k in range(5):
        q[:] = [k, 2 * k, 3 * k]
        n[()] = -k
        m[:] = [[k, 0], [0, 2 * k]]
        rec.row["t"][()] = 0.001 * k
        rec.record()
    rec.close()
    tel = read(tmp_path / "run.rtt")
    np.testing.assert_array_equal(tel["q"], np.outer(np.arange(5), [1, 2, 3]))
    np.testing.assert_array_equal(tel["t"], 0.001 * np.arange(5))
    np.testing.assert_array_equal(tel["n"], -np.arange(5))
    np.testing.assert_array_equal(tel["m"][:, 1, 1], 2 * np.arange(5))


def test_bind_checks_name_and_shape(tmp_path):
    rec = Recorder(tmp_path / "run.rtt", {"q": (3, "f8")})
    with pytest.raises(TelemetryError, match="no column 'qd'"):
        rec.bind("qd", np.zeros(3))
    for wrong in (np.zeros(4), np.zeros(3, np.float32), np.zeros(6)[::2], [0.0, 0.0, 0.0]):
        with pytest.raises(TelemetryError, match="binds a C-contiguous float64 array of shape"):
            rec.bind("q", wrong)
    rec.close()


def test_realtime_mode_drops_and_counts_rows_when_the_writer_stalls(tmp_path):
    rec = Recorder(tmp_path / "run.rtt", {"k": ((), "i8")}, block_rows=10, n_blocks=2)
    os.kill(rec._proc.pid, signal.SIGSTOP)  # a stalled disk, as far as the loop can tell
    try:
        kept = []
        for k in range(35):
            rec.row["k"][()] = k
            if rec.commit():
                kept.append(k)
    finally:
        os.kill(rec._proc.pid, signal.SIGCONT)
    assert kept == list(range(20))  # both blocks filled, then every row dropped, none blocked
    assert rec.dropped_rows == 15
    rec.close()
    tel = read(tmp_path / "run.rtt")
    np.testing.assert_array_equal(tel["k"], kept)
    assert tel.dropped_rows == 15 and tel.footer["rows"] == 20


def test_wait_mode_never_drops_with_a_tiny_ring(tmp_path):
    n = 2000
    rec = Recorder(tmp_path / "run.rtt", {"k": ((), "i8")}, block_rows=3, n_blocks=2, wait_when_full=True)
    for k in range(n):
        rec.row["k"][()] = k
        assert rec.commit()
    rec.close()
    np.testing.assert_array_equal(read(tmp_path / "run.rtt")["k"], np.arange(n))


def test_unserialisable_summary_still_saves_the_rows(tmp_path):
    rec = Recorder(tmp_path / "run.rtt", {"k": ((), "i8")})
    rec.row["k"][()] = 7
    rec.commit()
    rec.close(summary={"bad": object()})
    tel = read(tmp_path / "run.rtt")
    assert tel["k"].tolist() == [7] and "not msgpack-serialisable" in tel.footer["summary"]["error"]


def record_boundaries(path):
    """Byte offset after each record and the rows it carries, found by an independent parse."""
    unpacker = msgpack.Unpacker(open(path, "rb"))
    out = []
    for record in unpacker:
        out.append((unpacker.tell(), record["n"] if record["type"] == "batch" else 0))
    return out


def test_truncated_file_reads_every_complete_batch(tmp_path):
    n = 233
    data = random_rows(np.random.default_rng(7), n)
    path = tmp_path / "run.rtt"
    record(path, data, n, block_rows=20, n_blocks=2)
    full = path.read_bytes()
    bounds = record_boundaries(path)
    header_end = bounds[0][0]
    rng = np.random.default_rng(3)
    cuts = set(rng.integers(header_end, len(full), 60).tolist()) | {b for b, _ in bounds} | {header_end + 1}
    cut_path = tmp_path / "cut.rtt"
    for cut in sorted(cuts):
        cut_path.write_bytes(full[:cut])
        tel = read(cut_path)
        expected = sum(rows for end, rows in bounds if end <= cut)
        assert tel.rows == expected, cut
        assert tel.truncated == (cut not in {b for b, _ in bounds}), cut
        for name in SCHEMA:
            np.testing.assert_array_equal(tel[name], data[name][:expected])
        assert (tel.footer is not None) == (cut == len(full))


def test_file_cut_inside_the_header_is_an_error(tmp_path):
    path = tmp_path / "run.rtt"
    record(path, random_rows(np.random.default_rng(0), 3), 3)
    header_end = record_boundaries(path)[0][0]
    path.write_bytes(path.read_bytes()[:header_end - 1])
    with pytest.raises(TelemetryError, match="no complete header"):
        read(path)


def test_not_a_telemetry_file(tmp_path):
    path = tmp_path / "other.bin"
    path.write_bytes(msgpack.packb({"hello": 1}))
    with pytest.raises(TelemetryError, match="not an rtctl telemetry file"):
        read(path)
    with pytest.raises(TelemetryError, match="cannot open"):
        read(tmp_path / "missing.rtt")


def test_batch_with_wrong_column_length_is_reported(tmp_path):
    path = tmp_path / "run.rtt"
    rec = Recorder(path, {"k": ((), "i8")})
    rec.close()
    records = list(msgpack.Unpacker(open(path, "rb")))
    bad = msgpack.packb({"type": "batch", "n": 2, "columns": {"k": b"\0" * 8}})
    path.write_bytes(msgpack.packb(records[0]) + bad)
    with pytest.raises(TelemetryError, match="expected 16 bytes for 2 rows, got 8"):
        read(path)


@pytest.mark.parametrize("schema, message", [
    ({}, "empty"),
    ({"q": ((0,), "f8")}, ">= 1"),
    ({"q": ((3,), "U4")}, "numeric"),
    ({"q": "f8"}, "expected \\(shape, dtype\\)"),
])
def test_bad_schema_is_refused(tmp_path, schema, message):
    with pytest.raises(TelemetryError, match=message):
        Recorder(tmp_path / "run.rtt", schema)


def test_unwritable_path_is_a_clear_error(tmp_path):
    with pytest.raises(TelemetryError, match="cannot create telemetry file"):
        Recorder(tmp_path / "no" / "such" / "dir.rtt", {"k": ((), "i8")})


@pytest.mark.parametrize("wait_when_full", [False, True])
def test_a_dead_writer_never_blocks_the_loop_and_close_reports_it(tmp_path, wait_when_full):
    rec = Recorder(tmp_path / "run.rtt", {"k": ((), "i8")}, block_rows=5, n_blocks=2, wait_when_full=wait_when_full)
    rec._proc.kill()
    rec._proc.wait()
    results = []
    for k in range(30):
        rec.row["k"][()] = k
        results.append(rec.commit())
    assert results == [True] * 10 + [False] * 20 and rec.dropped_rows == 20 and not rec.writer_alive
    with pytest.raises(TelemetryError, match="writer .* failed \\(exit status -9\\); rows stored: 10"):
        rec.close()
    rec.close()  # the second close is a no-op


def test_full_disk_at_start_is_a_clear_error(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    with pytest.raises(TelemetryError, match="cannot write telemetry file /dev/full"):
        Recorder("/dev/full", {"k": ((), "i8")})
