"""Tests for control mutants that survived a sample of the suite (docs/mutation/control.md), each
against the documented behaviour or an independent reference (the leg automaton's are in
tests/leg/test_leg_actions.py):

* a non-finite coefficient estimate θ̂ is named as such — the first quantity checked;
* ARMA/GMV's ``R0`` may be left out, and 0 is a valid R̂(0) (≥ 0);
* the ARMA/GMV telemetry's ``u`` is the torque just commanded;
* Slotine–Li's ``params0`` file must exist and be .npy or .toml, said as such;
* the 4×4 Jacobi eigen-solver diagonalises a matrix whose off-diagonal squares sum to exactly 1
  (numpy's eigvalsh as the reference);
* a live-tunable parameter is an immutable binding (its value changes in place).
"""
import dataclasses

import numpy as np
import pytest

from arma_loop import SHIPPED, replaced, shipped
from rtctl.config import load_config
from rtctl.control.base import Reference
from rtctl.control.consistency import symmetric_eigen4
from rtctl.control.tunable import Tunable
from rtctl.errors import ConfigError, ControllerError
from rtctl.hal.joints import JointCommand, JointState
from rtctl.runtime import build


def _primed(tmp_path, **options):
    cfg, c = shipped(tmp_path, **options)
    n = cfg.model.nq
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:] = cfg.sim.vector("initial_q", n)
    ref.q[:] = state.position + 0.01
    c.reset(state)
    c.update(0.0, state, ref, cmd)
    return c, state, ref, cmd


def test_a_non_finite_coefficient_estimate_is_named(tmp_path):
    c, state, ref, cmd = _primed(tmp_path, adapt="{ r = true, R = true, q = false, Q = false }")
    c.filter.theta[0, 1] = np.nan
    with pytest.raises(ControllerError, match="joint 'shoulder': non-finite coefficient estimate θ̂"):
        c.update(0.02, state, ref, cmd)


def test_r0_may_be_left_out_and_may_be_zero(tmp_path):
    text = SHIPPED.read_text()
    assert "\nR0 = " in text
    cfg, c = shipped(tmp_path, R0="0.0")  # (accepted: R̂ then starts at its floor R_min)
    assert np.all(c.filter.signals[1] == cfg.controllers[0].options.float("R_min"))
    (tmp_path / "without").mkdir()
    path = tmp_path / "without" / "run.toml"
    path.write_text("\n".join(ln for ln in replaced(text, {}).splitlines() if not ln.startswith("R0 ")))
    c = build(load_config(path)).controllers[0]
    assert np.all(np.isfinite(c.filter.signals[1])) and np.all(c.filter.signals[1] >= 0.0)


def test_the_telemetrys_u_is_the_torque_just_commanded(tmp_path):
    c, state, ref, cmd = _primed(tmp_path)
    for k in range(1, 6):
        c.update(0.02 * k, state, ref, cmd)
        np.testing.assert_array_equal(c.internals["u"], cmd.tau_ff[c.joints])


@pytest.mark.parametrize("name, make", [("p0.txt", True), ("missing.npy", False)])
def test_params0_is_an_existing_npy_or_toml_file(tmp_path, name, make):
    from test_config import configured  # (tests/control: the Slotine–Li job's configuration)

    if make:
        np.savetxt(tmp_path / name, np.ones(60))
    with pytest.raises(ConfigError) as e:
        build(load_config(configured(tmp_path, f'params0 = "{name}"')))
    assert e.value.key_path == "controllers[0].params0"
    assert "an existing .npy/.toml file" in e.value.expected


def test_jacobi_diagonalises_off_diagonal_squares_summing_to_one():
    A = np.diag([2.0, 3.0, 4.0, 5.0])
    A[0, 1] = A[1, 0] = 1.0  # Σ_{a<b} A_ab² = 1 exactly
    reference = np.linalg.eigvalsh(A)
    V = np.zeros((4, 4))
    work = A.copy()
    symmetric_eigen4(work, V)
    np.testing.assert_allclose(np.sort(np.diag(work)), reference, rtol=1e-12)
    np.testing.assert_allclose(V @ np.diag(np.diag(work)) @ V.T, A, atol=1e-12)


def test_a_tunable_is_an_immutable_binding():
    value = np.zeros(3)
    t = Tunable(value, lambda table, key: table.float(key))
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.value = np.ones(3)
    t.set(np.ones(3))
    assert value.tolist() == [1.0, 1.0, 1.0]  # changed in place: what the telemetry views
