"""The guard through the daemon and the CLI: the shipped guarded run goes around the conveyor;
`rtctl move` to a target behind a zone plans around it, one inside a zone is refused while the
daemon runs on; `rtctl plan` prints and draws the path; `rtctl check` reports the bypasses."""
import json
import time

import numpy as np
import pytest

from guard_helpers import ROOT, depths, guard_section, rtctl, sim_config
from rtctl.telemetry import read

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

SHIPPED = ROOT / "configs" / "puma560_guard_sim.toml"
CT = '\n[[controllers]]\nname = "ct"\ntype = "computed_torque"\nkp = 400.0\nkd = 40.0\n'
BEHIND = ["0", "180", "-60", "0", "30", "0"]  # place behind: straight from ready it crosses the conveyor


def test_the_shipped_guarded_run_goes_around_the_conveyor(tmp_path):
    summary, telemetry = tmp_path / "s.json", tmp_path / "t.msgpack"
    result = rtctl("run", SHIPPED, "--realtime-factor", 0, "--duration", 7.5, "--summary", summary,
                   "--telemetry", telemetry, "--socket", tmp_path / "s.sock")
    assert result.returncode == 0, result.stderr[-2000:]
    s, tel = json.loads(summary.read_text()), read(telemetry)
    assert not [e for e in s["safety"]["events"] if e["event"] == "guard"]  # the plan never worried the guard
    d = depths(SHIPPED, tel["q"])
    print(f"closest approach {np.degrees(d.min()):.2f}° (margin 3°), tracking max {s['tracking_error_rad']['max_all']:.2e} rad")
    assert d.min() > np.radians(1.5)  # half the planned margin at least
    behind = tel["q"][:, 1] > np.radians(175)
    assert behind.any()  # it did get to the place behind …
    assert tel["q"][:, 2].min() < np.radians(-180)  # … by folding the elbow under the conveyor


def test_move_goes_around_a_zone_and_a_target_inside_one_is_refused(write, daemon, tmp_path):
    text = sim_config(CT, guard_section())  # lock-step, as fast as possible: no load-dependent skipped periods
    telemetry = tmp_path / "move.msgpack"
    d = daemon(write(text), "--telemetry", telemetry)
    d.wait_ready()
    refused = rtctl("move", "--deg", "--socket", d.socket, 0, 90, -120, 0, 0, 0)
    reply = json.loads(refused.stdout)
    assert refused.returncode == 3 and not reply["ok"] and "inside zone 'overhead_conveyor'" in reply["error"]
    moved = rtctl("move", "--deg", "--socket", d.socket, *BEHIND)
    reply = json.loads(moved.stdout)
    assert moved.returncode == 0 and len(reply["bypass"]) >= 2, reply
    while json.loads(rtctl("status", "--socket", d.socket).stdout)["t"] < reply["t_end"] + 0.2:
        time.sleep(0.2)
    status = json.loads(rtctl("status", "--socket", d.socket).stdout)
    assert status["ok"] and not status["faults"]  # still running, nothing latched
    assert np.allclose(status["q"], np.radians([float(x) for x in BEHIND]), atol=2e-3)
    rtctl("stop", "--socket", d.socket)
    assert d.finish()[0] == 0
    assert np.all(depths(d.summary.parent / "run.toml", read(telemetry)["q"]) > 0)


def test_plan_prints_and_draws_the_path_and_says_when_there_is_none(tmp_path):
    out = tmp_path / "plan.png"
    result = rtctl("plan", SHIPPED, "--to", *BEHIND, "--deg", "--plot", out)
    assert result.returncode == 0, result.stderr
    assert "enters zone 'overhead_conveyor'" in result.stdout and "path (visibility, 5 points" in result.stdout
    assert out.stat().st_size > 10_000
    inside = rtctl("plan", SHIPPED, "--to", 0, 90, -120, 0, 0, 0, "--deg")
    assert inside.returncode == 2 and "the target is inside zone 'overhead_conveyor'" in inside.stderr


def test_check_reports_the_crossings_and_the_bypasses():
    result = rtctl("check", SHIPPED)
    assert result.returncode == 0, result.stderr
    lines = [x for x in result.stdout.splitlines() if "bypass" in x]
    assert len(lines) == 2 and all("enters zone 'overhead_conveyor'" in x for x in lines)
    assert "leg start → 0: straight, clear" in result.stdout
