"""A controller writes the torques of the joints it owns and no other: the compiled controllers
do it inside their kernel (``emit_owned``), and two controllers share one command."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.control.base import Reference
from rtctl.control.computed_torque import ComputedTorque
from rtctl.control.pd_gravity import PDGravity
from rtctl.control.slotine_li import SlotineLi
from rtctl.hal.joints import JointCommand, JointState

SENTINEL = 123.0
OWNED = [0, 2, 5]


def _controllers(model):
    return [ComputedTorque("ct", model, 100.0, 20.0, joints=OWNED),
            SlotineLi(model, law="cstar", lam=10.0, kd=50.0, gamma=1.0, joints=OWNED, projection=True),
            SlotineLi(model, law="classic", lam=10.0, kd=50.0, gamma=1.0, joints=OWNED),
            PDGravity("pd", model, 100.0, 20.0, joints=OWNED)]


@pytest.mark.parametrize("which", range(4))
def test_only_the_owned_joints_torques_are_written(puma, which):
    controller = _controllers(puma)[which]
    n = puma.nq
    rng = np.random.default_rng(which)
    state, ref, command = JointState(n), Reference(n), JointCommand(n)
    state.position[:], state.velocity[:] = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    ref.packed[:] = rng.uniform(-1, 1, (3, n))
    command.tau_ff[:] = SENTINEL
    controller.update(0.0, state, ref, command)
    others = np.setdiff1d(np.arange(n), OWNED)
    assert np.all(command.tau_ff[others] == SENTINEL)
    assert np.all(command.tau_ff[OWNED] != SENTINEL) and np.all(np.isfinite(command.tau_ff[OWNED]))
    np.testing.assert_array_equal(command.tau_ff[OWNED], controller.tau[OWNED])
