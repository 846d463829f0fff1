"""``[sim] engine = "mujoco"``: the embedded simulator on MuJoCo, its options checked like the rest
of the configuration, and a clear exit 2 without the package."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
from runtime_helpers import BASE  # noqa: E402  (the PUMA job every runtime test starts from)

CONFIG = BASE.replace("[sim]\n", '[sim]\nengine = "mujoco"\n')
assert 'engine = "mujoco"' in CONFIG


def rtctl(*args, env=None):
    return subprocess.run([sys.executable, "-m", "rtctl.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=ROOT, env=env)


def test_without_the_package_the_engine_exits_2_saying_how_to_install_it(tmp_path):
    import os

    blocker = tmp_path / "blocked" / "mujoco"
    blocker.mkdir(parents=True)
    (blocker / "__init__.py").write_text("raise ImportError('no module named mujoco (blocked by the test)')\n")
    config = tmp_path / "run.toml"
    config.write_text(CONFIG)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(blocker.parent), str(ROOT)])}
    result = rtctl("check", config, env=env)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "sim.engine" in result.stderr and "pip install -e '.[mujoco]'" in result.stderr


@pytest.mark.parametrize("change, key, says", [
    (('engine = "mujoco"', 'engine = "bullet"'), "sim.engine", "one of 'rigid', 'mujoco'"),
    (('engine = "mujoco"', 'engine = "mujoco"\npayload = { mass = -2.0 }'), "sim.payload.mass", "positive"),
    (('engine = "mujoco"', 'engine = "mujoco"\npayload = { mass = 2.0, inertia = [1, 1, 3, 0, 0, 0] }'),
     "sim.payload.inertia", "the inertia of a rigid body"),
    (('engine = "mujoco"', 'engine = "mujoco"\npayload = { mass = 2.0, colour = "red" }'), "sim.payload.colour",
     "unknown key"),
])
def test_bad_engine_options_exit_2_naming_the_key(tmp_path, change, key, says):
    config = tmp_path / "run.toml"
    config.write_text(CONFIG.replace(*change))
    result = rtctl("check", config)
    assert result.returncode == 2, result.stdout + result.stderr
    assert key in result.stderr and says in result.stderr


@pytest.mark.slow
def test_computed_torque_tracks_on_mujoco(tmp_path):
    pytest.importorskip("mujoco", reason="the `mujoco` extra is not installed")
    config = tmp_path / "run.toml"
    config.write_text(CONFIG)
    summary = tmp_path / "summary.json"
    result = rtctl("run", config, "--duration", 3, "--summary", summary)
    assert result.returncode == 0, result.stderr[-2000:]
    s = json.loads(summary.read_text())
    # the true model's computed torque on a plant that is not rtctl's: friction as MuJoCo's dry-friction
    # constraint, the elbow's inertia made physical (docs/mujoco.md). Measured max 2.6e-3 rad, rms 4.9e-4.
    assert s["tracking_error_rad"]["max_all"] < 1e-2
    assert s["safety"]["faults"] == []
    assert np.isfinite(s["tracking_error_rad"]["rms_all"])
