"""The leg on contact physics (hil_sim/leg_mujoco.py): the heel and toe loads are the ground's
contact forces, and the leg automaton walks on them (configs/leg_mujoco.toml)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "leg"))
sys.path.insert(0, str(ROOT / "scripts"))
from leg_helpers import pattern_prefix  # noqa: E402  (the scripted walk's checker)

from drivers.protocols.leg_board import HOLD, RELEASE  # noqa: E402
from hil_sim.leg_mujoco import MujocoLegParams, MujocoLegPlant  # noqa: E402



def ground_force_on(plant, geom_name: str) -> float:
    """Normal force of the ground on one foot geom, summed over MuJoCo's contact list with
    mj_contactForce — computed apart from the touch sensors the plant reads."""
    m, d = plant.mj_model, plant.mj_data
    gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, geom_name)
    f6, total = np.zeros(6), 0.0
    for i in range(d.ncon):
        if gid in (d.contact[i].geom1, d.contact[i].geom2):
            mujoco.mj_contactForce(m, d, i, f6)
            total += f6[0]
    return total


def test_the_heel_load_rises_at_heel_strike_from_the_contact_not_a_script():
    """Knee held, ankle released, from mid-swing: the heel reads nothing until MuJoCo puts the heel
    sphere on the ground; what it reads is the ground's normal force over the body weight
    (mj_contactForce, independently of the touch sensor) at every step; within 50 ms of the strike
    it passes the h_d gate's 0.2 — the load that drives 2 → 3 comes from the contact."""
    plant = MujocoLegPlant(MujocoLegParams(angle_noise=0.0, load_noise=0.0), 1e-3)
    plant.actions[:] = (HOLD, RELEASE)
    heel_geom = mujoco.mj_name2id(plant.mj_model, mujoco.mjtObj.mjOBJ_GEOM, "heel")
    struck, peak = None, 0.0
    for k in range(1500):
        plant.step(1e-3)
        force = ground_force_on(plant, "heel") / (plant.mj_model.body_mass.sum() * 9.81)  # the whole body
        assert plant.loads[1] == pytest.approx(force, abs=1e-9), k
        bottom = plant.mj_data.geom_xpos[heel_geom, 2] - plant.mj_model.geom_size[heel_geom, 0]
        if struck is None:
            if plant.loads[1] > 0.0:
                struck = k
                assert bottom < 0.0  # in contact: the sphere reaches the ground
            else:
                assert bottom > -1e-4  # nothing under the heel, nothing read
        elif k - struck <= 50:
            peak = max(peak, plant.loads[1])
    assert struck is not None and peak > 0.2, (struck, peak)


def leg_job(tmp_path, *change) -> Path:
    """configs/leg_mujoco.toml with its relative paths made absolute, ``change`` = (old, new) applied."""
    text = (ROOT / "configs" / "leg_mujoco.toml").read_text()
    text = text.replace('description = "robots/', f'description = "{ROOT}/configs/robots/')
    text = text.replace('table = "leg/', f'table = "{ROOT}/configs/leg/').replace('path = "../runs/leg_mujoco.msgpack"', "")
    if change:
        assert change[0] in text
        text = text.replace(*change)
    path = tmp_path / "leg.toml"
    path.write_text(text)
    return path


def rtctl_check(config, env=None):
    return subprocess.run([sys.executable, "-m", "rtctl.cli", "check", str(config)], capture_output=True, text=True,
                          timeout=300, cwd=ROOT, env=env)


@pytest.mark.parametrize("change, key, says", [
    (("seed = 1", "seed = 1\nknee_push_rate = 100.0"), "sim.leg.knee_push_rate", "contact physics replaces it"),
    (("seed = 1", "seed = 1\nsupport = [0.5, 0.0, 0.0, 1.0, 1.5]"), "sim.leg.support", "in [0, 1]"),
    (("seed = 1", "seed = 1\nsubsteps = 0"), "sim.leg.substeps", "at least 1"),
    (("seed = 1", "seed = 1\nfoot_mass = 0.0"), "sim.leg.foot_mass", "a positive mass"),
    (("seed = 1", "seed = 1\nbody_mas = 70.0"), "sim.leg.body_mas", "unknown key"),
])
def test_bad_mujoco_leg_options_exit_2_naming_the_key(tmp_path, change, key, says):
    result = rtctl_check(leg_job(tmp_path, *change))
    assert result.returncode == 2, result.stdout + result.stderr
    assert key in result.stderr and says in result.stderr, result.stderr


def test_without_the_package_the_mujoco_leg_exits_2_saying_how_to_install_it(tmp_path):
    blocker = tmp_path / "blocked" / "mujoco"
    blocker.mkdir(parents=True)
    (blocker / "__init__.py").write_text("raise ImportError('no module named mujoco (blocked by the test)')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(blocker.parent), str(ROOT)])}
    result = rtctl_check(leg_job(tmp_path), env=env)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "sim.engine" in result.stderr and "pip install -e '.[mujoco]'" in result.stderr


def test_the_mujoco_job_keeps_the_scripted_jobs_gates():
    """Thresholds and hysteresis carried over unchanged: only the plant differs."""
    from rtctl.config import load_config

    gates = [load_config(ROOT / "configs" / name).controllers[0].options.data["gates"]
             for name in ("leg_sim.toml", "leg_mujoco.toml")]
    assert gates[0] == gates[1]


@pytest.mark.slow
def test_50_gait_cycles_on_mujoco_give_exactly_the_tables_sequence():
    """configs/leg_mujoco.toml as `rtctl run` builds it (the engine option picks the MuJoCo leg), walked
    51 gait periods from mid-swing: exactly (1 2 3 4 1 5 1 6)ⁿ, n ≥ 50, as on the scripted plant."""
    from leg_mujoco_gait import CONFIGS, PATTERN, walk

    seq, _ = walk(CONFIGS["MuJoCo"], 51 * 1.2)
    good = pattern_prefix(seq)
    assert good == len(seq), seq[max(0, good - 8): good + 8]
    assert (len(seq) - 1) // len(PATTERN) >= 50, len(seq)
