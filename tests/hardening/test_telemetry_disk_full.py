"""Defect 12: a telemetry writer that cannot write (a full disk) is an event at once, with a
policy — a safe stop by default, or running on without telemetry — and the summary is
written all the same. A full disk is played by a file-size limit (RLIMIT_FSIZE: the write
fails with EFBIG, as it would with ENOSPC), inherited by the writer process."""
from __future__ import annotations

import json
import resource
import subprocess
import sys

import pytest

from rtctl.telemetry import read
from runtime_helpers import BASE, ROOT

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

# ~300-byte rows in blocks of 100: the shared ring (4 blocks, a memfd: also under the limit)
# fits, the file holds ~8 blocks of the 2000 rows the run records
LIMIT = 256 * 1024
TELEMETRY = "\n[telemetry]\nbatch_rows = 100\n"


def _limited():
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, resource.RLIM_INFINITY))


def _run(config, tmp_path):
    telemetry, summary = tmp_path / "run.msgpack", tmp_path / "summary.json"
    result = subprocess.run([sys.executable, "-m", "rtctl.cli", "run", str(config), "--duration", "2",
                             "--telemetry", str(telemetry), "--summary", str(summary), "--socket", str(tmp_path / "s")],
                            capture_output=True, text=True, timeout=120, cwd=ROOT, preexec_fn=_limited)
    events = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    return result, events, json.loads(summary.read_text()), telemetry


@pytest.mark.parametrize("policy", ["stop", "continue"])
def test_defect_12_a_full_disk_is_reported_at_once_and_the_summary_written(write_config, tmp_path, policy):
    text = BASE + TELEMETRY + ("" if policy == "stop" else 'on_failure = "continue"\n')
    result, events, summary, telemetry = _run(write_config(text), tmp_path)
    failed = [e for e in events if e["event"] == "telemetry failed"]
    assert failed, result.stdout[-3000:] + result.stderr[-3000:]
    assert "File too large" in failed[0]["reason"]
    assert summary["telemetry"]["error"]
    ticks = summary["timing"]["ticks"]
    if policy == "stop":
        assert result.returncode == 3, result.stderr
        assert summary["exit_code"] == 3 and "telemetry" in summary["stop_reason"]
        assert ticks < 1500  # stopped when the writer failed, not at the end of the 2 s
    else:
        assert result.returncode == 0, result.stderr
        assert summary["exit_code"] == 0 and ticks >= 2000  # ran its course without telemetry
    rec = read(telemetry)  # what did reach the disk reads back
    assert 0 < rec.rows < ticks
