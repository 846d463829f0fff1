"""Defect 7: a real-time knob out of range is refused, and the daemon always answers SIGTERM."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import pytest

from rtctl.timing.rt import KnobStatus, RtSettings, apply_rt
from runtime_helpers import BASE, ROOT

pytestmark = pytest.mark.realtime  # (tests/conftest.py)


@pytest.mark.parametrize("slack", [2**63 - 1, 1_000_001, -1])
def test_defect_07_timer_slack_out_of_range_exits_2(write_config, capsys, slack):
    from rtctl.cli import main

    path = write_config(BASE.replace("[sim]", f"[loop.rt]\ntimer_slack_ns = {slack}\n\n[sim]"))
    assert main(["check", str(path)]) == 2
    assert "loop.rt.timer_slack_ns" in capsys.readouterr().err


def test_defect_07_apply_rt_refuses_a_huge_slack():
    (report,) = [r for r in apply_rt(RtSettings(timer_slack_ns=2**63 - 1)) if r.knob == "timer_slack"]
    assert report.status is KnobStatus.FAILED


def test_defect_07_sigterm_is_answered_during_a_long_sleep(write_config, tmp_path):
    # 1 Hz at a hundredth of real time: the loop sleeps 100 s between ticks
    text = BASE.replace("rate_hz = 1000.0", "rate_hz = 1.0").replace("realtime_factor = 0.0", "realtime_factor = 0.01")
    summary = tmp_path / "summary.json"
    proc = subprocess.Popen([sys.executable, "-m", "rtctl.cli", "run", str(write_config(text)), "--socket",
                             str(tmp_path / "s"), "--summary", str(summary)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        for line in proc.stdout:  # the loop is running once "started" is logged
            if '"started"' in line:
                break
        time.sleep(0.3)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=20)
        assert time.monotonic() - t0 < 10
    finally:
        proc.kill()
        proc.communicate()
    assert code == 0
    assert json.loads(summary.read_text())["stop_reason"] == "signal SIGTERM"
