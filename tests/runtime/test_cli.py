"""The command line as a user meets it: help for every subcommand, `rtctl model`, clear errors."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.model import dynamics, kinematics, load_robot
from runtime_helpers import PUMA, rtctl

SUBCOMMANDS = ["run", "check", "model", "status", "stop", "estop", "reset", "move", "plot", "export", "bench", "doctor"]


@pytest.mark.parametrize("sub", SUBCOMMANDS)
def test_every_subcommand_explains_itself(sub):
    result = rtctl(sub, "--help", timeout=60)
    assert result.returncode == 0 and "usage: rtctl" in result.stdout


def test_model_prints_the_robot_its_tool_pose_and_gravity():
    q = [0.1, 0.7, -2.5, 0.3, 0.4, 0.5]
    result = rtctl("model", PUMA, "--q", *q, timeout=120)
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "puma560: 6 joints" in out and "timing:" in out
    model = load_robot(PUMA)
    # the printed gravity vector is G(q) of the model (4 decimals)
    printed = out.split("gravity G(q) = [")[1].split("]")[0]
    assert np.allclose(np.array(printed.split(), dtype=float), dynamics.gravity(model, np.array(q)), atol=1e-4)
    assert f"{kinematics.fk(model, np.array(q))[0, 3]:.4f}" in out


def test_model_with_the_wrong_number_of_joints_is_a_clear_error():
    result = rtctl("model", PUMA, "--q", 0.1, 0.2, timeout=120)
    assert result.returncode == 2
    assert "--q" in result.stderr and "6 joint values" in result.stderr and "Traceback" not in result.stderr
