"""Issue 26 item 14: the leg's automaton follows no reference (its gait drives the joints), so a
leg run reports no "tracking error" — it used to report 0.25–0.46 rad against a constant target."""
from __future__ import annotations

import json
import subprocess
import sys

from leg_helpers import CONFIGS, ROOT


def test_a_leg_run_reports_no_tracking_error(tmp_path):
    summary = tmp_path / "s.json"
    r = subprocess.run([sys.executable, "-m", "rtctl.cli", "run", str(CONFIGS / "leg_sim.toml"), "--duration", "1.5",
                        "--realtime-factor", "0", "--progress", "0.001", "--log-format", "json", "--summary", str(summary),
                        "--socket", str(tmp_path / "s.sock"), "--telemetry", str(tmp_path / "t.msgpack")],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = [json.loads(line) for line in r.stdout.splitlines() if line.startswith("{")]
    running = [e for e in lines if e["event"] == "running"]
    assert running and not [e for e in running if "tracking_error" in e]
    assert "tracking_rms_rad" not in lines[-1] and lines[-1]["event"] == "summary"
    assert json.loads(summary.read_text())["tracking_error_rad"] is None
