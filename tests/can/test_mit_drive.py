"""The emulated MIT drive firmware on a stand-in 1-DoF plant: impedance law, torque limit, motor
modes, set zero, error state, watchdog, fault knobs, and the plant against closed forms."""
import math

import numpy as np
import pytest

from drivers.protocols import mit
from drivers.protocols.mit import KATZ, Special
from hil_sim.mit_drive import MappedJointPort, DriveFaults, InertiaJoint, MitDrive, MitDriveBus, free_running


class Port:
    """A joint frozen at (p, v) that records the torque it is given."""

    def __init__(self, p=0.0, v=0.0):
        self.p, self.v, self.tau = p, v, None

    def get_position(self):
        return self.p

    def get_velocity(self):
        return self.v

    def set_torque(self, tau):
        self.tau = tau


ENTER, EXIT = mit.special_frame(Special.ENTER_MOTOR_MODE), mit.special_frame(Special.EXIT_MOTOR_MODE)


def enabled_drive(port, **kw):
    d = MitDrive(1, port, **kw)
    assert d.receive(ENTER, 0.0) is not None and d.enabled
    return d


def test_impedance_law_with_the_quantised_command():
    port = Port(p=0.2, v=-0.1)
    d = enabled_drive(port)
    reply = d.receive(mit.pack_command(KATZ, 1.0, -2.0, 5.0, 1.0, 3.0), 0.001)
    # the drive sees the truncated values: p 35388, v 1984, kp int(5·4095/500 = 40.95) = 40,
    # kd 819, t 2388 (as in the codec's golden frames)
    p_des = 35388 * 25 / 65535 - 12.5
    v_des = 1984 * 130 / 4095 - 65
    kp, kd, t_ff = 40 * 500 / 4095, 819 * 5 / 4095, 2388 * 36 / 4095 - 18
    expected = kp * (p_des - 0.2) + kd * (v_des + 0.1) + t_ff
    assert port.tau == pytest.approx(expected, rel=1e-12)
    r = mit.unpack_reply(reply, KATZ)
    assert r.drive_id == 1 and r.effort == pytest.approx(expected, abs=36 / 4095)


def test_torque_is_clamped_to_the_model_limit():
    port = Port(p=-10.0)
    d = enabled_drive(port)
    d.receive(mit.pack_command(KATZ, 10.0, 0.0, 500.0, 0.0, 0.0), 0.001)
    assert port.tau == 18.0
    dm = enabled_drive(Port(p=10.0), model=mit.DRIVE_MODELS["dm4310"])
    dm.receive(mit.pack_command(dm.model, -10.0, 0.0, 500.0, 0.0, 0.0), 0.001)
    assert dm.torque == -10.0


def test_motor_off_outputs_zero_and_every_frame_is_answered():
    port = Port(p=0.5)
    d = MitDrive(1, port)
    assert d.receive(mit.pack_command(KATZ, 0.0, 0.0, 100.0, 1.0, 5.0), 0.0) is not None  # rest mode: answered
    assert port.tau == 0.0 and d.counters.commands == 1
    d.receive(ENTER, 0.001)
    d.receive(mit.pack_command(KATZ, 0.0, 0.0, 0.0, 0.0, 5.0), 0.002)
    assert port.tau == pytest.approx(5.0, abs=36 / 4095)
    d.receive(EXIT, 0.003)
    assert port.tau == 0.0 and not d.enabled
    d.receive(ENTER, 0.004)  # a stale command is not resumed
    assert port.tau == 0.0 and d.counters.replies == 5


def test_watchdog_turns_the_motor_off_after_the_timeout():
    port = Port()
    d = enabled_drive(port)
    d.receive(mit.pack_command(KATZ, 0.0, 0.0, 0.0, 0.0, 2.0), 0.005)
    d.update(0.025)  # exactly 20 ms after the last command: still on
    assert d.enabled and port.tau != 0.0
    d.update(0.0251)
    assert not d.enabled and port.tau == 0.0 and d.counters.watchdog_trips == 1
    d.receive(mit.pack_command(KATZ, 0.0, 0.0, 0.0, 0.0, 2.0), 0.03)  # needs ENTER again
    assert port.tau == 0.0


def test_set_zero_only_at_rest_and_error_state():
    port = Port(p=2.0)
    d = MitDrive(1, port, model=mit.MitDriveModel(reply_format=mit.ReplyFormat.CUBEMARS))
    r = mit.unpack_reply(d.receive(mit.special_frame(Special.SET_ZERO), 0.0), d.model)
    assert abs(r.position) < 25 / 65535 and d.zero_offset == 2.0
    d.receive(ENTER, 0.001)
    port.p = 3.0
    d.receive(mit.special_frame(Special.SET_ZERO), 0.002)
    assert d.zero_offset == 2.0 and d.counters.zero_refused == 1
    d.set_error(4)
    assert not d.enabled
    r = mit.unpack_reply(d.receive(ENTER, 0.003), d.model)
    assert r.error == 4 and not d.enabled  # no motor mode while in error
    r = mit.unpack_reply(d.receive(mit.special_frame(Special.CLEAR_ERROR), 0.004), d.model)
    assert r.error == 0
    d.receive(ENTER, 0.005)
    assert d.enabled


def test_malformed_frames_are_counted_not_answered():
    d = MitDrive(1, Port())
    assert d.receive(b"\x00" * 7, 0.0) is None
    assert d.receive(bytes.fromhex("FF FF FF FF FF FF FF 01"), 0.0) is None
    assert d.counters.malformed == 2 and d.counters.replies == 0


def test_fault_knobs():
    d = enabled_drive(Port())
    d.faults = DriveFaults(silent=True)
    assert d.receive(mit.pack_command(KATZ, 0, 0, 0, 0, 0), 0.001) is None and d.counters.commands == 0
    d.faults = DriveFaults(drop_rate=1.0)
    assert d.receive(mit.pack_command(KATZ, 0, 0, 0, 0, 0), 0.002) is None and d.counters.dropped == 1
    d.faults = DriveFaults(corrupt_rate=1.0)
    assert len(d.receive(mit.pack_command(KATZ, 0, 0, 0, 0, 0), 0.003)) == 3
    d.faults = DriveFaults(drop_rate=0.5, seed=7)
    answered = sum(d.receive(mit.pack_command(KATZ, 0, 0, 0, 0, 0), 0.004) is not None for _ in range(400))
    assert 150 < answered < 250


def test_delayed_replies_leave_through_service():
    drive = MitDrive(1, Port(), faults=DriveFaults(delay_s=0.003))
    bus = MitDriveBus([drive])
    out = []
    bus.receive(1, ENTER, 1.000, out)
    assert out == [] and bus.next_deadline() <= 1.003
    bus.service(1.002, out)
    assert out == []
    bus.service(1.003, out)
    assert len(out) == 1 and out[0][0] == 0
    bus.receive(0x123, b"", 1.004, out)
    bus.receive(1, ENTER, 1.004, out, is_extended=True)
    assert bus.ignored == 2


def test_inertia_joint_matches_the_closed_form():
    j = InertiaJoint(inertia=0.05, damping=0.2, position=1.0)
    j.set_torque(0.4)
    for _ in range(1000):
        j.step(1e-3)
    a, v_inf, t = 0.2 / 0.05, 0.4 / 0.2, 1.0
    assert j.velocity == pytest.approx(v_inf * (1 - math.exp(-a * t)), rel=1e-12)
    assert j.position == pytest.approx(1.0 + v_inf * (t - (1 - math.exp(-a * t)) / a), rel=1e-12)


def test_closed_loop_step_response_matches_the_second_order_solution():
    """Drive + plant: J p̈ + (b + kd) ṗ + kp p = kp p_des, underdamped; the drive's law is
    sampled at 5 kHz (zero-order hold), hence the tolerance."""
    joint = InertiaJoint(inertia=0.05, damping=0.05)
    drive = MitDrive(1, joint, timeout_s=10.0)
    advance = free_running([drive], substep=2e-4)
    advance(0.0)
    drive.receive(ENTER, 0.0)
    drive.receive(mit.pack_command(KATZ, 1.0, 0.0, 20.0, 1.0, 0.0), 0.0)
    c = drive.command  # the quantised gains the drive really uses
    J, b = 0.05, 0.05
    wn = math.sqrt(c.kp / J)
    zeta = (b + c.kd) / (2 * math.sqrt(c.kp * J))
    wd = wn * math.sqrt(1 - zeta**2)
    for t in np.arange(0.05, 0.6, 0.05):
        advance(t)
        exact = c.p * (1 - math.exp(-zeta * wn * t) * (math.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * math.sin(wd * t)))
        assert joint.position == pytest.approx(exact, abs=5e-3), t
    assert joint.position == pytest.approx(c.p, abs=2e-2)


def test_array_port_drives_one_joint_of_a_multi_joint_plant():
    q, qd, tau = np.array([0.0, 0.5]), np.array([0.0, -0.2]), np.zeros(2)
    d = enabled_drive(MappedJointPort(q, qd, tau, 1))
    d.receive(mit.pack_command(KATZ, 0.0, 0.0, 0.0, 5.0, 0.0), 0.001)
    c = d.command  # v_des and t_ff decode to −65/4095 and −18/4095, not 0
    assert tau[0] == 0.0 and tau[1] == pytest.approx(c.kd * (c.v + 0.2) + c.t, rel=1e-12)
    assert mit.unpack_reply(d._answer(), KATZ).position == pytest.approx(0.5, abs=25 / 65535)


def test_scheduled_fault_injection():
    drive = MitDrive(1, Port())
    bus = MitDriveBus([drive])
    bus.call_at(2.0, lambda: setattr(drive.faults, "silent", True))
    out = []
    bus.receive(1, ENTER, 1.0, out)
    assert len(out) == 1 and bus.next_deadline() <= 2.0
    bus.service(1.999, out)
    assert not drive.faults.silent
    bus.service(2.0, out)
    out.clear()
    bus.receive(1, ENTER, 2.001, out)
    assert drive.faults.silent and out == []
