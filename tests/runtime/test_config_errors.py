"""A bad configuration exits 2 before any device is touched, naming file, key path and expectation."""
from __future__ import annotations

import pytest

from runtime_helpers import BASE, rtctl


CASES = [
    # (what is wrong, edit of the base config, key path the message must name, words of the expectation)
    ("missing key", lambda s: s.replace('[robot]\ndescription', '[robot]\ndescriptio'), "robot.description", "missing"),
    ("wrong type", lambda s: s.replace("rate_hz = 1000.0", 'rate_hz = "fast"'), "loop.rate_hz", "finite number"),
    ("unknown key", lambda s: s.replace("rate_hz = 1000.0", "rate_hz = 1000.0\nrte_hz = 5"), "loop.rte_hz", "unknown key"),
    ("impossible value", lambda s: s.replace("rate_hz = 1000.0", "rate_hz = -5.0"), "loop.rate_hz", "positive"),
    ("unknown gain", lambda s: s.replace("kd = 40.0", "kd = 40.0\nkpp = 3.0"), "controllers[0].kpp", "unknown key"),
    ("waypoint past a limit", lambda s: s.replace("[30, 30, -160", "[30, 300, -160"), "trajectory.waypoints[1][1]", "limits"),
    ("unknown controller", lambda s: s.replace('type = "computed_torque"', 'type = "magic"'), "controllers[0].type", "one of"),
    ("two owners", lambda s: s + '\n[[controllers]]\nname = "pd"\ntype = "pd_gravity"\nkp = 1.0\nkd = 1.0\n',
     "controllers[1].joints", "one controller per joint"),
    ("not TOML", lambda s: s + "\n[[[", "<syntax>", "valid TOML"),
    ("following window per joint, too few", lambda s: s + "\n[safety]\nfollowing_error = [0.1, 0.1]\n",
     "safety.following_error", "array of 6 numbers"),
    ("following window of zero", lambda s: s + "\n[safety]\nfollowing_error = [0.1, 0.1, 0.0, 0.1, 0.1, 0.1]\n",
     "safety.following_error", "positive numbers"),
]


@pytest.mark.parametrize("what, edit, key, expected", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("command", ["check", "run"])
def test_bad_config_exits_2_naming_the_key(write_config, command, what, edit, key, expected):
    path = write_config(edit(BASE))
    result = rtctl(command, path, timeout=60)
    assert result.returncode == 2, result.stderr
    assert str(path) in result.stderr
    assert key in result.stderr
    assert expected in result.stderr
    assert "Traceback" not in result.stderr
    assert '"event": "started"' not in result.stdout  # no device was brought up


def test_good_config_checks(write_config):
    result = rtctl("check", write_config(), timeout=60)
    assert result.returncode == 0, result.stderr
    assert "OK" in result.stdout


def test_missing_file_exits_2(tmp_path):
    result = rtctl("check", tmp_path / "nope.toml")
    assert result.returncode == 2 and "nope.toml" in result.stderr
