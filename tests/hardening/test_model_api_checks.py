"""Defect 5: the public kinematics and dynamics check shapes and dtypes before a compiled
kernel sees them — ValueError (TypeError for None) saying what was expected, never a segfault
or a pose read from uninitialised memory. Run in a child process: the old code segfaulted."""
from __future__ import annotations

import numpy as np
import pytest

from model_api_subprocess import outcomes, run_child
from rtctl.model import dynamics as dyn
from rtctl.model import kinematics as kin

CASES = '''
from rtctl.model import load_robot, kinematics as kin, dynamics as dyn
puma = load_robot("configs/robots/puma560.toml")
for q_name, q in (("206 values", np.zeros(206)), ("4 values", np.zeros(4)), ("2-D", np.zeros((1, 6))),
                  ("None", None), ("strings", ["a"] * 6), ("complex", np.zeros(6, complex)), ("nan", np.full(6, np.nan))):
    outcome(f"fk {q_name}", lambda: kin.fk(puma, q))
    outcome(f"jacobian {q_name}", lambda: kin.jacobian(puma, q))
    outcome(f"link_poses {q_name}", lambda: kin.link_poses(puma, q))
    outcome(f"tool_twist {q_name}", lambda: kin.tool_twist(puma, q, np.zeros(6)))
    outcome(f"joint_rates {q_name}", lambda: kin.joint_rates(puma, q, np.zeros(6)))
    outcome(f"gravity {q_name}", lambda: dyn.gravity(puma, q))
arrays, data = dyn.model_arrays(puma), dyn.Data(puma)
q = np.zeros(6)
outcome("mass_matrix_into 5x5 output", lambda: dyn.mass_matrix_into(arrays, data, q, np.zeros((5, 5))))
outcome("mass_matrix_into 200x200 output", lambda: dyn.mass_matrix_into(arrays, data, q, np.zeros((200, 200))))
outcome("mass_matrix_into q of 300", lambda: dyn.mass_matrix_into(arrays, data, np.zeros(300), np.zeros((6, 6))))
outcome("rnea_into tau of 2", lambda: dyn.rnea_into(arrays, data, q, q, q, np.zeros(2)))
outcome("gravity_into float32", lambda: dyn.gravity_into(arrays, data, q.astype(np.float32), np.zeros(6)))
read_only = np.zeros(6)
read_only.setflags(write=False)
outcome("gravity_into read-only output", lambda: dyn.gravity_into(arrays, data, q, read_only))
outcome("forward_dynamics_into Data of another robot",
        lambda: dyn.forward_dynamics_into(arrays, dyn.Data(load_robot("configs/robots/two_link.toml")), q, q, q, q, np.zeros(6)))
outcome("rnea_into params of 3 links", lambda: dyn.rnea_into(arrays._replace(params=np.zeros((3, 10))), data, q, q, q, np.zeros(6)))
outcome("coriolis_matrix_into kind 7", lambda: dyn.coriolis_matrix_into(arrays, data, q, q, 7, np.zeros((6, 6))))
'''


def test_defect_05_wrong_shapes_raise_instead_of_crashing():
    seen = outcomes(run_child(CASES))
    assert len(seen) == 7 * 6 + 9
    for name, x in seen.items():
        assert "raised" in x, (name, x)  # none of these calls has an answer
        assert x["raised"] in ("ValueError", "TypeError"), (name, x)
        assert "expected" in x["message"], (name, x)


def test_defect_05_into_checks_once_then_catches_a_new_wrong_array(puma):
    arrays, data = dyn.model_arrays(puma), dyn.Data(puma)
    q, H = np.zeros(6), np.zeros((6, 6))
    dyn.mass_matrix_into(arrays, data, q, H)
    np.testing.assert_allclose(H, dyn.mass_matrix(puma, q))
    with pytest.raises(ValueError, match=r"shape \(6, 6\)"):
        dyn.mass_matrix_into(arrays, data, q, np.zeros((7, 7)))  # a new array is checked again


def test_defect_05_messages_say_what_was_expected(puma):
    with pytest.raises(ValueError, match=r"q: expected 6 joint values \(shape \(6,\)\), got shape \(4,\)"):
        kin.fk(puma, np.zeros(4))
    with pytest.raises(TypeError, match="got None"):
        kin.jacobian(puma, None)


def test_defect_05_the_checked_into_forms_allocate_nothing_per_call():
    from allocations import growth_and_peak
    from random_robots import make_random_chain

    n = 100  # a temporary vector (8 n bytes) would stand out from numba's argument tuples (≤ 0.6 kB)
    model = make_random_chain(n, seed=3)
    arrays, data = dyn.model_arrays(model), dyn.Data(model)
    q, g, H = np.zeros(n), np.zeros(n), np.zeros((n, n))

    def tick():
        dyn.gravity_into(arrays, data, q, g)
        dyn.mass_matrix_into(arrays, data, q, H)

    tick()
    growth, peak = growth_and_peak(tick, 2000)
    assert growth <= 64 and peak < 8 * n, (growth, peak)
