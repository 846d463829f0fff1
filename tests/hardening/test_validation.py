"""Defects 6, 10 and 13: every number of a configuration is finite and in range, every
argument is checked, and all of it — the trajectory's plan included — before a device is
touched: exit 2 naming the file or option and the key, never a traceback."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from runtime_helpers import BASE, ROOT, rtctl

HIL = (ROOT / "configs" / "puma560_hil_socketcand.toml").read_text().replace(
    'description = "robots/', f'description = "{ROOT}/configs/robots/')


def _assert_exit_2(result, *words):
    assert result.returncode == 2, result.stdout + result.stderr
    assert "Traceback" not in result.stderr
    for w in words:
        assert w in result.stderr, (w, result.stderr)
    assert '"event": "started"' not in result.stdout


def test_defect_06_nan_waypoint_exits_2_before_the_bus_is_opened(write_config):
    path = write_config(HIL.replace("[30, 20, -30, 30, 30, 45]", "[30, 20, nan, 30, 30, 45]"))
    # nothing listens on port 1: a run that opened the bus would fail with exit 4
    result = rtctl("run", path, env={**os.environ, "HIL_SIM_PORT": "1"}, timeout=60)
    _assert_exit_2(result, str(path), "trajectory.waypoints[1][2]", "finite")
    assert "exit motor mode" not in result.stdout + result.stderr


def test_defect_06_a_trajectory_the_limits_refuse_exits_2_at_check(write_config, capsys):
    from rtctl.cli import main

    # every waypoint is within the limits, but the planner refuses the smooth path through them
    # (it ends on every joint's limit); `run` used to find out only after the devices were up
    text = BASE.replace("waypoints = [[0, 45, -180, 0, 45, 0], [30, 30, -160, 20, 60, 30], [0, 45, -180, 0, 45, 0]]",
                        "waypoints = [[34, 152, -78, 152, 63, -265], [114, -36, -28, -61, 73, 22], "
                        "[160, -45, 45, 170, 100, 266]]\nsmooth = true")
    assert main(["check", str(write_config(text))]) == 2
    err = capsys.readouterr().err
    assert "trajectory: waypoints the limits allow" in err and "violates the limits" in err, err


@pytest.mark.parametrize("edit, key", [
    (("kp = 400.0", "kp = nan"), "controllers[0].kp"),
    (("kd = 40.0", "kd = inf"), "controllers[0].kd"),
    (("kp = 400.0", "kp = [400.0, 400.0, -inf, 400.0, 400.0, 400.0]"), "controllers[0].kp"),
    (("kp = 400.0", "kp = [400.0, 400.0, -1.0, 400.0, 400.0, 400.0]"), "controllers[0].kp[2]"),
    (("velocity_scale = 0.4", "velocity_scale = nan"), "trajectory.velocity_scale"),
    (("substeps = 4", "substeps = 4\nfriction = -inf"), "sim.friction"),
])
def test_defect_10_non_finite_or_out_of_range_numbers_exit_2_naming_the_key(write_config, capsys, edit, key):
    from rtctl.cli import main

    path = write_config(BASE.replace(*edit))
    assert main(["check", str(path)]) == 2  # in-process: the same code as the subprocess, faster
    err = capsys.readouterr().err
    assert f"{path}: {key}" in err, err


def test_defect_10_messages_name_the_key(write_config, capsys):
    from rtctl.cli import main

    path = write_config(BASE.replace("kp = 400.0", "kp = nan"))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: controllers[0].kp: a finite number, got nan" in err


@pytest.mark.parametrize("args, option", [
    (["--duration", "nan"], "--duration"),  # ran forever
    (["--duration", "-1"], "--duration"),
    (["--realtime-factor", "nan"], "--realtime-factor"),  # tracebacks
    (["--realtime-factor", "inf"], "--realtime-factor"),
])
def test_defect_13_bad_run_arguments_exit_2(write_config, capsys, args, option):
    from rtctl.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["run", str(write_config()), *args])
    assert exit_.value.code == 2
    assert f"argument {option}: expected a finite number" in capsys.readouterr().err


def test_defect_13_a_realtime_factor_too_small_to_tick_exits_2(write_config):
    from argparse import Namespace

    from rtctl.daemon import prepare
    from rtctl.errors import ConfigError

    with pytest.raises(ConfigError, match="--realtime-factor"):
        prepare(Namespace(config=write_config(), sim=False, realtime_factor=1e-9))


def test_defect_13_config_not_utf8_exits_2(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(BASE.replace("[loop]", "# caf\xe9\n[loop]").encode("latin-1"))
    _assert_exit_2(rtctl("check", path), str(path), "UTF-8")


@pytest.mark.parametrize("where", ["parent is a file", "parent cannot be created"])
def test_defect_13_bad_telemetry_parent_exits_2(write_config, tmp_path, where):
    from argparse import Namespace

    from rtctl.daemon import prepare
    from rtctl.errors import ConfigError

    if where == "parent is a file":
        (tmp_path / "plain").write_text("")
        telemetry = tmp_path / "plain" / "run.msgpack"
    elif os.geteuid() == 0:
        telemetry = Path("/proc/rtctl-no/run.msgpack")  # root may write anywhere but /proc
    else:
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        telemetry = locked / "sub" / "run.msgpack"
    args = Namespace(config=write_config(), sim=False, realtime_factor=None, telemetry=str(telemetry), summary=None,
                     socket=str(tmp_path / "s"), enforce_rt=False, duration=0.1)
    daemon = prepare(args)
    with pytest.raises(ConfigError, match="--telemetry: a file in a directory"):
        daemon.run()  # in-process: the old code raised a bare OSError (a traceback, exit 1)
    assert daemon.ticker.tick == -1  # the loop never started


def test_fuzz_finding_a_plant_without_inertia_exits_2_at_check(write_config, tmp_path, capsys):
    """The model-API fuzzer found forward dynamics dividing by zero for a joint with no inertia
    and no armature; a simulated run of such a robot now exits 2 at check instead of raising in
    its first tick."""
    from rtctl.cli import main

    robot = tmp_path / "massless.toml"
    robot.write_text('name = "massless"\n' + "".join(f'[[joints]]\nname = "j{k}"\nalpha = 0\na = 0.5\nd = 0\n'
                                                   for k in range(2)))
    text = BASE.replace(f"{ROOT}/configs/robots/puma560.toml", str(robot)).replace(
        "initial_q = [0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0]", "initial_q = [0.0, 0.0]").split("[trajectory]")[0]
    assert main(["check", str(write_config(text))]) == 2
    assert "sim.armature" in capsys.readouterr().err
