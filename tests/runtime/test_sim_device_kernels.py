"""The embedded simulator's device: its read and write are one compiled call each, bit-for-bit the
numpy expressions they replaced, and they allocate nothing that lasts."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from allocations import growth_and_peak
from hil_sim.embedded import command_torque, measure
from rtctl.config import load_config
from rtctl.hal import Status
from rtctl.runtime import build

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "puma560_sim.toml"


def test_measure_is_the_numpy_gather_and_encoder_floor_bit_for_bit():
    rng = np.random.default_rng(3)
    q, qd, tau = rng.uniform(-4, 4, (3, 7))
    idx = np.array([5, 0, 3], dtype=np.int64)
    quantum = 2 * np.pi / 4096
    pos, vel, eff = np.zeros((3, 3))
    measure(q, qd, tau, idx, quantum, pos, vel, eff)
    np.testing.assert_array_equal(pos, np.floor(q[idx] / quantum) * quantum)
    np.testing.assert_array_equal(vel, qd[idx])
    np.testing.assert_array_equal(eff, tau[idx])
    measure(q, qd, tau, idx, 0.0, pos, vel, eff)  # no encoder: the plant's position as it is
    np.testing.assert_array_equal(pos, q[idx])


def test_command_torque_is_the_drives_impedance_law_bit_for_bit():
    rng = np.random.default_rng(4)
    q_des, qd_des, kp, kd, tau_ff, pos, vel = rng.uniform(-50, 50, (7, 3))
    idx = np.array([2, 4, 1], dtype=np.int64)
    tau_cmd = np.full(6, 7.0)
    command_torque(True, q_des, qd_des, kp, kd, tau_ff, pos, vel, idx, tau_cmd)
    expected = np.full(6, 7.0)
    expected[idx] = (q_des - pos) * kp + tau_ff + (qd_des - vel) * kd  # the order a drive adds them in
    np.testing.assert_array_equal(tau_cmd, expected)
    command_torque(False, q_des, qd_des, kp, kd, tau_ff, pos, vel, idx, tau_cmd)
    expected[idx] = tau_ff
    np.testing.assert_array_equal(tau_cmd, expected)


def test_sim_device_read_and_write_allocate_nothing():
    rt = build(load_config(CONFIG, sim=True))
    (dev,) = rt.devices
    dev.configure()
    dev.activate()
    dev.command.mode = 1
    dev.command.kp[:] = 10.0

    def tick():
        assert dev.read(0.0) == Status.OK and dev.write(0.0) == Status.OK

    for _ in range(50):
        tick()
    growth, peak = growth_and_peak(tick, 2000)
    assert np.all(np.isfinite(dev.state.position))
    # nothing kept; the transient peak is numba boxing the calls' arguments, freed at return
    assert growth <= 64 and peak < 1024, (growth, peak)
