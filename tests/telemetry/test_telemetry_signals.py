"""A recording process stopped by SIGTERM (or killed) keeps every row it recorded on disk."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from rtctl.telemetry import read

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

SCRIPT = Path(__file__).with_name("record_until_signal.py")


def start(path, mode):
    proc = subprocess.Popen([sys.executable, str(SCRIPT), str(path), mode], stdout=subprocess.PIPE,
                            text=True, start_new_session=True)
    assert proc.stdout.readline().strip() == "ready"
    return proc


def wait_for_stored(proc, at_least):
    for line in proc.stdout:
        if line.startswith("stored") and int(line.split()[1]) >= at_least:
            return int(line.split()[1])
    raise AssertionError("recording process ended early")


def check_rows(tel, n):
    np.testing.assert_array_equal(tel["tick"], np.arange(n))
    check_row_contents(tel, n)


def check_row_contents(tel, recorded):
    """Whatever was dropped, each row on disk is whole and is the row of its own tick."""
    tick = tel["tick"]
    assert np.all(np.diff(tick) > 0) and (tick.size == 0 or 0 <= tick[0] and tick[-1] < recorded)
    np.testing.assert_array_equal(tel["t"], tick)
    np.testing.assert_array_equal(tel["q"], tick[:, None] + np.arange(6))


@pytest.mark.parametrize("mode", ["paced", "fast"])
def test_sigterm_to_the_process_group_loses_no_recorded_row(tmp_path, mode):
    path = tmp_path / "run.rtt"
    proc = start(path, mode)
    wait_for_stored(proc, 500)  # mid-block at some point after this
    os.killpg(proc.pid, signal.SIGTERM)  # as systemd does: loop and writer both get it
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0
    last = out.strip().splitlines()[-1].split()  # "recorded N dropped D"
    assert last[0] == "recorded"
    recorded, dropped = int(last[1]), int(last[3])
    tel = read(path)
    assert tel.footer["clean"] and tel.footer["summary"] == {"ticks": recorded}
    assert tel.rows + dropped == recorded and tel.dropped_rows == dropped
    if mode == "fast":
        assert dropped == 0  # the as-fast-as-possible recorder waits instead of dropping
    check_row_contents(tel, recorded)
    if dropped == 0:
        check_rows(tel, recorded)


def test_sigkill_of_the_loop_process_still_saves_every_stored_row(tmp_path):
    path = tmp_path / "run.rtt"
    proc = start(path, "paced")
    seen = wait_for_stored(proc, 750)
    proc.kill()  # the loop process only: a crash, no close(), no signal handler
    proc.wait()
    deadline = time.monotonic() + 30  # the orphaned writer saves the rows, then the footer
    while time.monotonic() < deadline:
        tel = read(path)
        if tel.footer is not None:
            break
        time.sleep(0.05)
    assert tel.footer is not None and tel.footer["clean"] is False
    assert tel.rows >= seen and tel.rows == tel.footer["rows"]
    check_rows(tel, tel.rows)
