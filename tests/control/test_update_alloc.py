"""Every registered controller's update() allocates nothing that lasts and no array-sized
temporary, built from a configuration as a run builds it; and PD + gravity against Pinocchio."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from allocations import growth_and_peak
from rtctl.config import load_config
from rtctl.control import CONTROLLERS
from rtctl.control.base import Reference
from rtctl.control.pd_gravity import PDGravity
from rtctl.hal.joints import JointCommand, JointState
from rtctl.runtime import build

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
# the joint controllers, each in the shipped configuration that runs it (pd_gravity: the baseline
# as an edit of the computed-torque job); the two others have their own tracemalloc tests, next to
# the devices they read: leg_automaton in tests/leg/test_controller.py, marker_observer in
# tests/vision/test_vision_alloc.py
SHIPPED = {"computed_torque": "puma560_sim.toml", "slotine_li": "puma560_cstar_sim.toml",
           "arma_gmv": "puma3_arma_gmv_sim.toml", "pd_gravity": "puma560_sim.toml"}
ELSEWHERE = {"leg_automaton", "marker_observer"}


def test_every_registered_controller_has_an_allocation_test():
    assert set(CONTROLLERS) == set(SHIPPED) | ELSEWHERE


def _runtime(type_name, tmp_path):
    path = CONFIGS / SHIPPED[type_name]
    if type_name == "pd_gravity":
        text = path.read_text().replace('type = "computed_torque"', 'type = "pd_gravity"')
        text = text.replace('description = "robots/', f'description = "{CONFIGS}/robots/')
        path = tmp_path / "pd.toml"
        path.write_text(text)
    rt = build(load_config(path))
    (controller,) = [c for c in rt.controllers if type(c).__module__.endswith(type_name)]
    return rt, controller


@pytest.mark.parametrize("type_name", sorted(SHIPPED))
def test_update_allocates_nothing(type_name, tmp_path):
    rt, controller = _runtime(type_name, tmp_path)
    n = rt.model.nq
    rng = np.random.default_rng(1)
    rt.state.position[:] = 0.5 * (rt.model.q_min + rt.model.q_max) + rng.uniform(-0.1, 0.1, n)
    rt.state.velocity[:] = rng.uniform(-0.5, 0.5, n)
    rt.ref.q[:] = rt.state.position + 0.01
    controller.reset(rt.state)
    t = [0.0]

    def tick():
        t[0] += 1e-3
        controller.update(t[0], rt.state, rt.ref, rt.command)

    for _ in range(50):
        tick()
    growth, peak = growth_and_peak(tick, 2000)
    assert np.all(np.isfinite(rt.command.tau_ff))
    # nothing kept (an array kept per call would grow the total by ≥ 8 n bytes a call); the
    # transient peak is numba's dispatcher boxing the call's arguments, freed at return — measured
    # 216 B (computed torque, PD) and ≈ 0.9 kB (ARMA/GMV, C* Slotine–Li)
    assert growth <= 64 and peak < 1024, (growth, peak)


def test_pd_gravity_is_pinocchios_gravity_plus_the_pd_law(puma, random_chain):
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the reference")

    def to_pin_q(pm, q):  # continuous joints are (cos, sin) in Pinocchio
        out = np.zeros(pm.nq)
        for joint, value in zip(list(pm.joints)[1:], q):
            out[joint.idx_q:joint.idx_q + joint.nq] = (np.cos(value), np.sin(value)) if joint.nq == 2 else value
        return out

    rng = np.random.default_rng(7)
    for model in (puma, random_chain(5, seed=3)):
        pm = pin.buildModelFromXML(model.to_urdf())
        pd = pm.createData()
        n = model.nq
        kp, kd = rng.uniform(10, 100, n), rng.uniform(1, 10, n)
        c = PDGravity("pd", model, kp, kd)
        state, ref, command = JointState(n), Reference(n), JointCommand(n)
        for _ in range(5):
            state.position[:], state.velocity[:] = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
            ref.q[:], ref.qd[:] = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
            c.update(0.0, state, ref, command)
            G = pin.computeGeneralizedGravity(pm, pd, to_pin_q(pm, state.position))
            expected = G + kp * (ref.q - state.position) + kd * (ref.qd - state.velocity)
            np.testing.assert_allclose(command.tau_ff, expected, rtol=1e-9, atol=1e-9)
