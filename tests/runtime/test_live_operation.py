"""Live operation of a running daemon (rtctl.live): switching controllers back and forth, a gain
changed mid-run, bad changes refused — end to end, daemon and CLI as subprocesses, checked from
the telemetry file it records."""
from __future__ import annotations

import json
import time

import numpy as np
import pytest

from rtctl.telemetry import read
from runtime_helpers import BASE, ROOT, rtctl
from test_daemon import frame, raw_request

pytestmark = [pytest.mark.slow, pytest.mark.realtime]  # (tests/conftest.py)

# computed torque drives the PUMA; C* Slotine–Li (π̂(0) = the model's × 0.8) waits to be switched in
SWITCHABLE = BASE.replace("[trajectory]", """
[[controllers]]
name = "adaptive"
type = "slotine_li"
active = false
lam = 10.0
kd = [80.0, 120.0, 40.0, 15.0, 15.0, 15.0]
gamma = { mass = 2.0, first_moment = 2.0, inertia = 0.5 }
params0 = "scaled"
params_scale = 0.8
projection = true
motor_model = true

[trajectory]""").replace("waypoints = [[0, 45, -180, 0, 45, 0], [30, 30, -160, 20, 60, 30], [0, 45, -180, 0, 45, 0]]",
                         "waypoints = [" + ", ".join(["[0, 45, -180, 0, 45, 0], [30, 30, -160, 20, 60, 30]"] * 12)
                         + ", [0, 45, -180, 0, 45, 0]]")


def ask(socket_path, **request):
    return raw_request(socket_path, frame(request))


def wait_until(socket_path, t_sim: float) -> float:
    """Poll ``status`` until the daemon's simulated time reaches ``t_sim``."""
    while True:
        t = ask(socket_path, cmd="status")["t"]
        if t >= t_sim:
            return t
        time.sleep(0.002)


def switch_ticks(tel) -> np.ndarray:
    active = tel["controllers_active"]
    return np.flatnonzero(np.any(np.diff(active, axis=0) != 0, axis=1)) + 1


def test_switching_ct_and_slotine_li_ten_times_is_bumpless_tracks_and_is_recorded(write_config, daemon, tmp_path):
    telemetry = tmp_path / "run.msgpack"
    d = daemon(write_config(SWITCHABLE), "--telemetry", telemetry, "--duration", 60)
    d.wait_ready()
    replies = []
    for i in range(20):  # ct → adaptive → ct …, every 0.4 s of the run's time (later if the machine stalls)
        wait_until(d.socket, 1.0 + 0.4 * i)
        to = "adaptive" if i % 2 == 0 else "ct"
        replies.append(ask(d.socket, cmd="switch", activate=[to], estimates="keep"))
    wait_until(d.socket, replies[-1]["t"] + 0.5)
    ask(d.socket, cmd="stop")
    code, _, err = d.finish()
    assert code == 0, err
    assert all(r["ok"] for r in replies), replies
    assert [r["started"] for r in replies] == [["adaptive"], ["ct"]] * 10
    assert [r["stopped"] for r in replies] == [["ct"], ["adaptive"]] * 10

    tel = read(telemetry)
    ticks = switch_ticks(tel)
    assert len(ticks) == 20  # each switch is in the telemetry, at the tick it took effect
    assert tel["controllers_active"][ticks].tolist() == [[0, 1], [1, 0]] * 10
    np.testing.assert_allclose(tel["t"][ticks], [r["t"] for r in replies], atol=2e-3)
    events = json.loads(d.summary.read_text())["operator"]["events"]
    assert [e["event"] for e in events] == ["switch"] * 20 and [e["tick"] for e in events] == [r["tick"] for r in replies]

    tau, e = tel["tau"], np.abs(tel["q"] - tel["q_des"])
    for k in ticks:
        # bumpless: the command at the switch continues the one before it (rtctl.switching, the bound);
        # unblended, it steps by 1.3–8.6 N·m here (measured by planting that bug)
        np.testing.assert_allclose(tau[k], tau[k - 1], atol=1e-9)
        # and in the 0.3 s after it changes per tick as the controllers' own commands do (measured ≤ 1.9 N·m:
        # computed torque taking up the adaptive controller's error, ≤ 2.0 N·m per tick before the switches)
        assert np.abs(np.diff(tau[k:k + 300], axis=0)).max() < 3.0
        # tracking after each switch (measured max 0.19°, after the first; 0.05° by the last)
        assert np.degrees(e[k:k + 400].max()) < 0.5


def test_a_gain_set_mid_run_changes_the_response_as_the_new_gain_predicts(write_config, daemon, tmp_path):
    """Computed torque without the drive train in its model: the armature and friction it does not
    compensate are a disturbance d, and the tracking error is e ≈ −H⁻¹ d / K_P while d varies slowly
    (ë + K_D ė + K_P e = −H⁻¹ d). Quadrupling K_P (with K_D doubled: ζ stays 1) must cut the error
    on the same segments of the same periodic motion to about a quarter."""
    text = BASE.replace("kd = 40.0", "kd = 40.0\nmotor_model = false").replace(
        "substeps = 4", "substeps = 4\nfriction = 1.0\narmature = true").replace(
        "waypoints = [[0, 45, -180, 0, 45, 0], [30, 30, -160, 20, 60, 30], [0, 45, -180, 0, 45, 0]]",
        "waypoints = [" + ", ".join(["[0, 45, -180, 0, 45, 0], [30, 30, -160, 20, 60, 30]"] * 6)
        + ", [0, 45, -180, 0, 45, 0]]\ndurations = [0.5" + ", 1.0" * 12 + "]").replace(
        # paced at twice real time, not as fast as possible: a lock-step run ended (and closed its socket)
        # before a test descheduled for a second on a loaded machine had seen t = 3.7 s; paced, the set has
        # 2.6 s of wall time to land in the window the comparison needs (3.7–9 s), whatever else runs
        "realtime_factor = 0.0", "realtime_factor = 2.0")  # A → B → A … from 0.5 s, period 2 s
    telemetry = tmp_path / "run.msgpack"
    d = daemon(write_config(text), "--telemetry", telemetry, "--duration", 12.5)
    d.wait_ready()
    wait_until(d.socket, 3.7)  # (as fast as possible: the raw socket, not the CLI's start-up time)
    kp, kd = ask(d.socket, cmd="set", key="ct.kp", value=1600), ask(d.socket, cmd="set", key="ct.kd", value=80.0)
    assert kp["ok"] and kd["ok"] and kp["old"] == [400.0] * 6, (kp, kd)
    code, _, err = d.finish()
    assert code == 0, err
    tel = read(telemetry)
    t, e = tel["t"], tel["q"] - tel["q_des"]
    first = np.flatnonzero(tel["ct.kd"][:, 0] == 80.0)[0]
    changed = t[first]
    # where it was asked, recorded: the last row with the old gain before the reply's time, the first
    # with the new one at or after it (paced, a writer starved for 2 s on a loaded machine drops rows)
    assert t[first - 1] <= kd["t"] <= changed and changed >= 3.7, (t[first - 1], changed, kd)
    if tel["t"].size == round(tel["t"][-1] / 1e-3) + 1:  # no row dropped: the very tick
        assert changed == pytest.approx(kd["t"], abs=2e-3)
    assert set(tel["ct.kp"][t < 3.7, 0]) == {400.0} and set(tel["ct.kp"][t > changed, 0]) == {1600.0}
    # B → A → B before the set, and the same two segments a whole number of periods later, once the
    # new gains' transient is over (when the set lands depends on the machine: a poll or two after 3.7 s)
    start = 1.5 + 2.0 * np.ceil((changed + 0.5 - 1.5) / 2.0)
    assert start + 2.0 <= 12.5, f"the set landed too late ({changed:.2f} s) to compare a period after it"
    before = np.sqrt(np.mean(e[(t >= 1.5) & (t < 3.5)] ** 2, axis=0))
    after = np.sqrt(np.mean(e[(t >= start) & (t < start + 2.0)] ** 2, axis=0))
    ratio = after[:3] / before[:3]
    assert np.all((ratio > 0.15) & (ratio < 0.4)), ratio  # ≈ K_P,old / K_P,new = 0.25


@pytest.mark.parametrize("args, says", [
    (("set", "ct.kp", "-1"), "ct.kp: a number ≥ 0.0, got -1"),
    (("set", "ct.kp", "[1, 2]"), "ct.kp: an array of 6 numbers"),
    (("set", "ct.kp", "nan"), "ct.kp: a finite number"),
    (("set", "ct.kp", "fast"), "ct.kp: VALUE must be written as in the configuration file"),
    (("set", "ct.motor_model", "false"), "ct.motor_model: not a parameter 'ct' can change at run time"),
    (("set", "loop.rate_hz", "500"), "loop.rate_hz: cannot change at run time"),
    (("set", "robot.description", "1"), "robot.description: cannot change at run time: the robot model"),
    (("set", "devices.sim", "1"), "devices.sim: cannot change at run time: the device layout"),
    (("set", "nosuch.kp", "1"), "nosuch.kp: no controller 'nosuch'"),
    (("get", "ct"), "expected \"NAME.KEY\""),
    (("switch",), "name controllers to activate"),
])
def test_every_bad_change_exits_2_naming_the_key_and_changes_nothing(write_config, daemon, args, says):
    d = daemon(write_config(BASE.replace("realtime_factor = 0.0", "realtime_factor = 1.0")), "--duration", 30)
    d.wait_ready()
    before = ask(d.socket, cmd="get", key="ct.kp")["value"]
    result = rtctl(*args, "--socket", d.socket)
    assert result.returncode == 2, result.stdout + result.stderr
    said = result.stderr + (json.loads(result.stdout)["error"] if result.stdout else "")
    assert says in said
    assert ask(d.socket, cmd="get", key="ct.kp")["value"] == before == [400.0] * 6
    ask(d.socket, cmd="stop")
    d.finish()


def test_controllers_lists_types_joints_rates_states_and_tunable_parameters(write_config, daemon):
    d = daemon(write_config(SWITCHABLE.replace("realtime_factor = 0.0", "realtime_factor = 1.0")), "--duration", 30)
    d.wait_ready()
    listed = rtctl("controllers", "--socket", d.socket)
    changed = rtctl("set", "adaptive.kd", "[80, 120, 40, 15, 15, 16]", "--socket", d.socket)
    got = rtctl("get", "adaptive.kd", "--socket", d.socket)
    ask(d.socket, cmd="stop")
    d.finish()
    assert listed.returncode == 0, listed.stderr
    rows = {c["name"]: c for c in json.loads(listed.stdout)["controllers"]}
    joints = ["waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange"]
    assert rows["ct"] == {"name": "ct", "type": "computed_torque", "joints": joints, "rate_hz": 1000.0,
                          "state": "active", "parameters": ["kd", "kp"]}
    assert rows["adaptive"]["state"] == "inactive" and rows["adaptive"]["parameters"] == ["kd", "lam"]
    assert changed.returncode == 0 and json.loads(changed.stdout)["new"] == [80, 120, 40, 15, 15, 16]
    assert got.returncode == 0 and json.loads(got.stdout)["value"] == [80, 120, 40, 15, 15, 16]


def test_the_switch_config_in_configs_is_valid():
    result = rtctl("check", ROOT / "configs" / "puma560_switch_sim.toml")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "controllers: ct (computed_torque), adaptive (slotine_li)" in result.stdout
