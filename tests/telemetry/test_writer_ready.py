"""The loop starts only once the telemetry writer is attached (Recorder.wait_ready)."""
import numpy as np
import pytest

import rtctl.telemetry.recorder as recorder_module
from rtctl.errors import TelemetryError
from rtctl.telemetry import Recorder, read
from rtctl.telemetry.ring import READY

SCHEMA = {"t": ((), np.float64), "q": ((3,), np.float64)}


def test_wait_ready_returns_once_the_writer_process_has_attached(tmp_path):
    rec = Recorder(tmp_path / "t.msgpack", SCHEMA, block_rows=4, n_blocks=2, wait_when_full=True)
    rec.wait_ready()
    assert rec._ctl[READY] == 1  # set by the writer process (spawning it takes far longer than returning)
    for k in range(20):
        rec.row["t"][()] = k
        rec.commit()
    rec.close()
    np.testing.assert_array_equal(read(tmp_path / "t.msgpack").columns["t"], np.arange(20.0))


def test_a_writer_that_exits_while_starting_is_a_telemetry_error_naming_the_file(tmp_path, monkeypatch):
    spawn = recorder_module.spawn_ring_reader

    def broken(module, config, fds):  # a schema it cannot read: it fails before it is ready
        return spawn(module, {**config, "schema": "garbage"}, fds)

    monkeypatch.setattr(recorder_module, "spawn_ring_reader", broken)
    rec = Recorder(tmp_path / "t.msgpack", SCHEMA)
    with pytest.raises(TelemetryError, match=r"t\.msgpack exited \(1\) before it started"):
        rec.wait_ready()
    with pytest.raises(TelemetryError):  # (and closing says it failed)
        rec.close()
