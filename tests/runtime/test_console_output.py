"""What `rtctl run` prints: readable lines and a summary table on a terminal (a pty here), strict
JSON lines otherwise; the summary file is strict JSON too (no NaN/Infinity anywhere)."""
from __future__ import annotations

import json
import os
import pty
import shutil
import subprocess
import sys
import time

import pytest

from runtime_helpers import BASE, ROOT, rtctl

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

PACED = BASE.replace("realtime_factor = 0.0", "realtime_factor = 1.0")


def _reject(constant):
    raise ValueError(f"non-standard JSON constant {constant}")


def strict_loads(text: str):
    return json.loads(text, parse_constant=_reject)


def test_on_a_terminal_the_run_ends_with_a_summary_table(write_config, tmp_path):
    leader, follower = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "rtctl.cli", "run", str(write_config(PACED)), "--duration", "1.3",
                             "--socket", str(tmp_path / "s")], stdout=follower, stderr=follower, cwd=ROOT)
    os.close(follower)
    out = b""
    while True:
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        out += chunk
    os.close(leader)
    assert proc.wait(timeout=60) == 0
    text = out.decode()
    assert not any(line.lstrip().startswith("{") for line in text.splitlines())  # no JSON on a terminal
    assert "started" in text and "stop" in text
    assert "running" in text  # a progress line every second on a terminal: never silent for long
    table = text[text.index("run summary"):].splitlines()
    assert table[0].startswith("run summary — duration reached (exit 0)")
    assert table[1].split()[0] == "ticks" and int(table[1].split()[1]) >= 300
    busy = table[2].split()  # the loop's share of its core: its compute and spin, at most the wall time
    assert busy[:2] == ["core", "busy"] and 0 < float(busy[2]) <= 100 and busy[3] == "%"
    head = table[3].split()
    assert head == ["µs", "p50", "p99", "max"]
    compute = next(line for line in table if line.strip().startswith("compute tick")).split()
    assert float(compute[-1]) >= float(compute[-2]) >= float(compute[-3]) > 0  # max ≥ p99 ≥ p50
    tracking = table.index(next(line for line in table if "tracking (mrad)" in line))
    assert table[tracking].split()[2:] == ["waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange", "all"]
    assert table[tracking + 1].split()[0] == "rms" and len(table[tracking + 1].split()) == 8
    assert "faults none" in text


def test_json_logs_and_summary_are_strict_even_with_a_fault(daemon, write_config, tmp_path):
    d = daemon(write_config(PACED), "--log-format", "json")
    d.wait_ready()
    time.sleep(0.3)
    assert rtctl("estop", "--socket", d.socket).returncode == 0  # a fault record whose value is NaN
    time.sleep(0.5)
    assert rtctl("stop", "--socket", d.socket).returncode == 0
    code, out, err = d.finish()
    lines = out.splitlines()
    records = [strict_loads(line) for line in lines]
    assert records and all(isinstance(r, dict) and r["event"] for r in records)
    assert not any(r["event"] == "running" for r in records)  # no progress lines in JSON logs unless asked
    fault = next(r for r in records if r["event"] == "fault")
    assert fault["kind"] == "estop" and fault["value"] is None
    assert records[-1]["event"] == "summary" and records[-1]["exit_code"] == code
    summary_text = d.summary.read_text()
    summary = strict_loads(summary_text)
    assert summary["safety"]["faults"][0]["value"] is None
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: checked with Python's strict parser only")
    script = "const fs=require('fs');let n=0;for(const f of process.argv.slice(1)){const t=fs.readFileSync(f,'utf8');" \
             "for(const l of (f.endsWith('.jsonl')?t.split('\\n').filter(x=>x):[t])){JSON.parse(l);n++}}console.log(n)"
    (tmp_path / "log.jsonl").write_text(out)
    parsed = subprocess.run([node, "-e", script, str(tmp_path / "log.jsonl"), str(d.summary)],
                            capture_output=True, text=True, timeout=60)
    assert parsed.returncode == 0, parsed.stderr
    assert int(parsed.stdout) == len(lines) + 1


def test_progress_lines_every_so_often_when_asked(write_config, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "rtctl.cli", "run", str(write_config(PACED)), "--duration", "1.2",
                           "--log-format", "json", "--progress", "0.25", "--socket", str(tmp_path / "s")],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    running = [r for r in map(strict_loads, proc.stdout.splitlines()) if r["event"] == "running"]
    times = [r["t"] for r in running]
    # one every 0.25 s of wall time (paced: loop time follows the wall clock, skipped periods included)
    assert len(running) >= 3 and all(b - a > 0.2 for a, b in zip(times, times[1:])), running
    assert all(r["duration"] == 1.2 and r["ticks"] > 0 and 0 <= r["tracking_error"] < 0.1 for r in running)
