"""`rtctl check` on configurations that name environment variables, and the wording of the
errors a newcomer meets first (a missing file, a missing robot file)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from runtime_helpers import BASE, ROOT, rtctl

SHIPPED = sorted((ROOT / "configs").glob("*.toml"))
CLEAN_ENV = {k: v for k, v in os.environ.items() if not k.startswith("HIL_SIM_")}


@pytest.mark.parametrize("config", SHIPPED, ids=[p.name for p in SHIPPED])
def test_every_shipped_config_checks_without_its_variables_set(config):
    result = rtctl("check", config, env=CLEAN_ENV, timeout=60)
    assert result.returncode == 0, result.stderr
    assert f"{config.relative_to(ROOT)}: OK" in result.stdout or f"{config}: OK" in result.stdout


def test_check_lists_the_variables_a_run_needs():
    config = ROOT / "configs" / "three_joint_slcan.toml"
    unset = rtctl("check", config, env=CLEAN_ENV)
    line = next(x for x in unset.stdout.splitlines() if x.split()[:1] == ["HIL_SIM_TTY"])
    assert "devices[0].bus.channel" in line and "NOT SET" in line
    set_ = rtctl("check", config, env={**CLEAN_ENV, "HIL_SIM_TTY": "/dev/pts/77"})
    line = next(x for x in set_.stdout.splitlines() if x.split()[:1] == ["HIL_SIM_TTY"])
    assert "'/dev/pts/77'" in line and "NOT SET" not in line


def test_run_without_the_variable_says_what_to_do():
    result = rtctl("run", ROOT / "configs" / "three_joint_slcan.toml", env=CLEAN_ENV)
    assert result.returncode == 2
    assert "devices[0].bus.channel: uses ${HIL_SIM_TTY}, which is not set: set HIL_SIM_TTY" in result.stderr


def test_a_deferred_value_does_not_hide_the_other_errors(write_config):
    text = f"""
[robot]
description = "{ROOT / 'configs' / 'robots' / 'puma560.toml'}"

[loop]
rate_hz = 250.0

[[devices]]
name = "arm"
driver = "mit_can"
ids = [1, 2, 3, 4, 5, 6]

[devices.bus]
interface = "nonsense"
channel = "${{NO_SUCH_VARIABLE_HERE}}"
"""
    result = rtctl("check", write_config(text), env=CLEAN_ENV)
    assert result.returncode == 2, result.stdout
    assert "devices[0].bus.interface" in result.stderr and "nonsense" in result.stderr


@pytest.mark.parametrize("command", ["check", "run"])
def test_a_missing_file_is_not_found(tmp_path, command):
    result = rtctl(command, tmp_path / "nope.toml")
    assert result.returncode == 2
    assert result.stderr.strip() == f"rtctl: configuration error: {tmp_path / 'nope.toml'}: not found"


def test_a_missing_robot_file_names_the_config_and_its_key(write_config):
    path = write_config(BASE.replace(str(ROOT / "configs" / "robots" / "puma560.toml"), "robots/nope.toml"))
    result = rtctl("check", path)
    assert result.returncode == 2
    message = result.stderr.strip()
    assert message.startswith(f"rtctl: configuration error: {path}: robot.description: ")
    assert f"{Path(path).parent / 'robots' / 'nope.toml'} not found" in message
