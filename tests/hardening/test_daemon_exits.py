"""Defects 3 and 4: how `rtctl run` ends when a fault is still latched, and when a second
daemon is started on the first one's control socket or telemetry file."""
from __future__ import annotations

import json
import time

import pytest

from rtctl.telemetry import read
from runtime_helpers import BASE, rtctl

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

# on the wall clock at a rate a loaded test machine keeps (and no overrun stop: timing is not what
# is tested here), telemetry in blocks of 100 rows
PACED = (BASE.replace("realtime_factor = 0.0", "realtime_factor = 1.0").replace(
    "rate_hz = 1000.0", "rate_hz = 250.0\noverrun_limit = 1000000")
         + "\n[telemetry]\nbatch_rows = 100\n")
# no trajectory, the waist started beyond its limit (±160°): a position fault at tick 0, whose
# fallback holds for fault_off_delay = 1 s, longer than the run
OUT_OF_RANGE = BASE.replace("initial_q = [0.0", "initial_q = [2.97").split("[trajectory]")[0]


def test_defect_03_a_fault_within_its_off_delay_does_not_exit_0(write_config, tmp_path):
    summary = tmp_path / "summary.json"
    result = rtctl("run", write_config(OUT_OF_RANGE), "--duration", "0.5", "--socket", tmp_path / "s",
                   "--summary", summary, timeout=120)
    assert result.returncode == 3, result.stderr
    s = json.loads(summary.read_text())
    assert s["exit_code"] == 3
    assert any(f["kind"] == "position" for f in s["safety"]["faults"])


def test_defect_04_a_second_daemon_leaves_the_first_ones_telemetry_alone(write_config, daemon, tmp_path):
    telemetry = tmp_path / "run.msgpack"
    config = write_config(PACED)
    first = daemon(config, "--telemetry", telemetry)
    first.wait_ready()
    time.sleep(0.8)  # the first blocks (100 rows each) are on disk
    size_before = telemetry.stat().st_size
    summary = tmp_path / "second.json"
    second = rtctl("run", config, "--telemetry", telemetry, "--socket", tmp_path / "second.sock",
                   "--summary", summary, "--duration", "0.5", timeout=120)
    assert second.returncode == 6, second.stderr
    assert "Traceback" not in second.stderr and "held" not in second.stderr and "another running rtctl" in second.stderr
    assert json.loads(summary.read_text())["exit_code"] == 6
    assert telemetry.stat().st_size >= size_before > 0  # not truncated under the first daemon
    assert rtctl("stop", "--socket", first.socket).returncode == 0
    code, _, err = first.finish()
    assert code == 0, err
    run = read(telemetry)
    first_summary = json.loads(first.summary.read_text())
    assert not run.truncated and run.footer is not None
    assert run.rows == first_summary["telemetry"]["rows"] == first_summary["timing"]["ticks"] > 100
    assert (run["t"] > 0).sum() == run.rows - 1  # no hole of zeros
