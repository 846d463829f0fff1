"""HIL on CiA 402: `hil-sim` plays the PUMA 560 and its CiA 402 drives (python-canopen nodes from
the driver's EDS) on two socketcand buses; `rtctl run` closes the loop at 500 Hz in cyclic
synchronous torque. Three of its joints also run over slcan (a pty), whose adapter acknowledges
every frame sent. The fault matrix as for the MIT drives: a silent drive, a frozen loop, a
dropped connection, corrupted TPDOs, a drive fault with its EMCY code — each ends in a
controlled state, with every tick in the telemetry and no drive left enabled."""

import numpy as np
import pytest

import hil_helpers
from hil_helpers import check_reopened_and_stopped, rtctl, run, run_with_a_frozen_loop, unless_stalled, variant

pytestmark = pytest.mark.hil

CONFIG = "puma560_hil_cia402.toml"
# no overrun stop: a loaded CI machine reached the limit of 50 before the fault under test was
# injected (two socketcand round trips per 2 ms tick leave little slack on a slow, shared VM)
NO_OVERRUN_STOP = {"overrun_limit": 1000000}
# the silent-drive test keeps the shipped 3-tick stale limit (a 100 ms RPDO deadline), its fault
# at command set 100 as in test_hil_faults; the others tolerate a stall (hil_helpers.STALL_TOLERANT)
TOLERANT = {**NO_OVERRUN_STOP, "drive_timeout": 0.1}
STALL_TOLERANT = {**NO_OVERRUN_STOP, **hil_helpers.STALL_TOLERANT}


def check_complete(summary, telemetry, sim_exit):
    assert telemetry.rows == summary["timing"]["ticks"] == summary["telemetry"]["rows"]
    assert all(dev["lifecycle"] == "closed" for dev in summary["devices"].values())
    assert not any(d["enabled"] for d in sim_exit["drives"]), "a drive was left enabled"


def test_check_prints_the_bus_load_of_the_pdo_set(tmp_path):
    result = rtctl("check", variant(tmp_path, CONFIG), timeout=60)
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines() if line.startswith("can")]
    # per drive RPDO 4 B + TPDO 8 B + TPDO 4 B = 95 + 135 + 95 bits, one SYNC of 55 bits per bus
    assert rows == [["can0", "cia402", "3", "500", "1000", "1030", "52%"],
                    ["can1", "cia402", "3", "500", "1000", "1030", "52%"]]
    one_bus = variant(tmp_path, CONFIG, name="one.toml", channel='"can0"')  # both devices on can0
    result = rtctl("check", one_bus, timeout=60)
    assert result.returncode == 2 and "devices[1].bus" in result.stderr and "SYNC" in result.stderr


def test_puma560_tracks_in_cst_over_socketcand_at_500hz(tmp_path, hil_sim):
    config = variant(tmp_path, CONFIG, **STALL_TOLERANT)
    sim = hil_sim(config, "--port", 0)
    assert sim.info["channels"] == ["can0", "can1"]
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=4.0)
    sim_exit = sim.stop()
    check_complete(summary, telemetry, sim_exit)
    with unless_stalled(summary):
        assert code == 0, (summary["stop_reason"], summary["timing"]["overruns"])
    for name in ("arm", "wrist"):
        counters = summary["devices"][name]["counters"]
        assert counters["malformed_replies"] == 0 and counters["bus_errors"] == 0 and counters["emcy"] == 0
        assert counters["cycles"] == summary["timing"]["ticks"] and counters["heartbeats"] > 0
    # one SYNC per bus per tick: the lock-step plant advanced once per tick
    assert sim_exit["cycles"] == summary["timing"]["ticks"]
    assert all(d["counters"]["syncs"] >= summary["timing"]["ticks"] for d in sim_exit["drives"])
    # Measured over socketcand to hil-sim on a 2-core VM, 20 runs in a row (2026-12-01, since
    # write() no longer waits for the TPDOs — the next read() collects them): tick p50 0.84-1.04
    # ms of 2 ms, 7-75 overruns in ~1950 ticks, max 3.3-23.2 mrad, RMS 0.21-0.90 mrad, all exit 0;
    # the bounds are 3× the worst. (Before, with both buses' round trips in write(): tick p50
    # 1.6 ms, 10-35 % overruns, max up to 36.1 mrad, RMS up to 2.23 mrad.)
    tracking = summary["tracking_error_rad"]
    print(f"CST tracking: max {tracking['max_all']:.4f} rad, rms {tracking['rms_all']:.4f} rad, "
          f"overruns {summary['timing']['overruns']}/{summary['timing']['ticks']}")
    with unless_stalled(summary):
        assert tracking["max_all"] < 3 * 0.0232 and tracking["rms_all"] < 3 * 0.00090, tracking
    assert np.all(np.ptp(telemetry["q"], axis=0)[:3] > np.radians(20))  # it did move


def test_a_silent_drive_is_a_safe_stop_within_3_ticks(tmp_path, hil_sim):
    config = variant(tmp_path, CONFIG, **TOLERANT)
    sim = hil_sim(config, "--port", 0, "--fault", "silent:3@100")
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=3.0)
    sim_exit = sim.stop()
    assert code == 3, err[-3000:]
    check_complete(summary, telemetry, sim_exit)
    assert summary["stop_reason"] != "overrun limit reached", summary["stop_reason"]
    faults = summary["safety"]["faults"]
    first = faults[0]
    at_first = {(f["kind"], f["joint"]) for f in faults if f["tick"] == first["tick"]}
    with unless_stalled(summary):  # a stall can make another drive stale first (seen in CI), or
        # stop the run before the scripted silence at command set 500 (node 3 then disabled by command;
        # seen in a 10x loop: the wrist's TPDOs 3 ticks late at tick 68, with 27 overruns in 293 ticks)
        assert [(e["kind"], e["drive"]) for e in sim.of("fault")] == [("silent", 3)], (faults[:4], sim.events)
        assert {("device_error", 0), ("stale", 2)} <= at_first, faults  # the elbow: node 3
    stale = [e for e in summary["devices"]["arm"]["events"] if e["event"] == "stale"][0]
    after = np.count_nonzero((telemetry["t"] > stale["missing_since"]) & (telemetry["t"] <= first["t"]))
    print(f"silent CiA 402 drive: fallback {after} ticks after its first missing TPDOs")
    assert after == 3, (first, stale)
    # node 3 heard nothing more: its RPDO deadline took its torque off; the others were disabled
    offs = {e["drive"]: e["cause"] for e in sim.of("motor_off")}
    assert offs[3] == "watchdog" and all(offs[i] == "command" for i in (1, 2, 4, 5, 6)), offs


def test_a_frozen_loop_lets_the_drives_disable_themselves(tmp_path, hil_sim):
    config = variant(tmp_path, CONFIG, **NO_OVERRUN_STOP)  # the drives' 20 ms RPDO deadline
    sim = hil_sim(config, "--port", 0)
    code, summary, telemetry, err = run_with_a_frozen_loop(config, tmp_path, sim.info["env"])
    sim_exit = sim.stop()
    offs = [e for e in sim.of("motor_off") if e["cause"] == "watchdog"]
    assert sorted(e["drive"] for e in offs) == [1, 2, 3, 4, 5, 6], sim.events
    late = [e["since_command_ms"] for e in offs]
    print(f"RPDO deadline: drives disabled {min(late):.1f}-{max(late):.1f} ms after the last RPDO")
    assert all(20.0 <= ms <= 30.0 for ms in late), late
    assert code == 3, err[-3000:]
    for name in ("arm", "wrist"):
        events = {e["event"] for e in summary["devices"][name]["events"]}
        assert "drives_off" in events, summary["devices"][name]["events"]
    check_complete(summary, telemetry, sim_exit)


def test_a_dropped_connection_is_reopened_and_stopped_safely_within_2_s(tmp_path, hil_sim):
    config = variant(tmp_path, CONFIG, **STALL_TOLERANT)  # (a stall must not stop it before the drop)
    sim = hil_sim(config, "--port", 0, "--fault", "drop@100")
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=4.0)
    sim_exit = sim.stop()
    assert code == 3, err[-3000:]
    check_complete(summary, telemetry, sim_exit)
    for device in ("arm", "wrist"):  # measured: reopened after 0.05 s, drives off after 0.50 s
        check_reopened_and_stopped(summary, device)
    assert sim_exit["server"]["connections"] >= 4  # both buses reconnected


def test_corrupted_tpdos_are_counted_and_ignored(tmp_path, hil_sim):
    config = variant(tmp_path, CONFIG, **STALL_TOLERANT)
    sim = hil_sim(config, "--port", 0, "--fault", "corrupt:2:0.02")
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=3.0)
    sim_exit = sim.stop()
    check_complete(summary, telemetry, sim_exit)
    with unless_stalled(summary):
        assert code == 0, (summary["stop_reason"], summary["safety"]["faults"][:3], err[-1000:])
        assert summary["tracking_error_rad"]["max_all"] < 0.05
    corrupted = {d["drive"]: d["counters"]["corrupted"] for d in sim_exit["drives"]}
    assert corrupted[2] > 10 and sum(corrupted.values()) == corrupted[2]
    assert summary["devices"]["arm"]["counters"]["malformed_replies"] == corrupted[2]
    assert np.all(np.isfinite(telemetry["q"]))


def test_a_drive_fault_is_a_safe_stop_naming_its_emcy_code(tmp_path, hil_sim):
    config = variant(tmp_path, CONFIG, **STALL_TOLERANT)
    sim = hil_sim(config, "--port", 0, "--fault", f"error:5:{0x2310}@100")  # over current on the wrist
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=3.0)
    sim_exit = sim.stop()
    assert code == 3, err[-3000:]
    check_complete(summary, telemetry, sim_exit)
    (fault,) = [e for e in summary["devices"]["wrist"]["events"] if e["event"] == "drive_fault"]
    assert fault["drive"] == 5 and fault["code"] == 0x2310 and "0x2310" in fault["reason"]
    first = summary["safety"]["faults"][0]
    assert first["kind"] == "device_error" and first["t"] - fault["t"] <= 0.004  # the tick it arrived, or the next
    assert {e["drive"]: e["cause"] for e in sim.of("motor_off")}[5] == "error"


# the bounds of the MIT drives over slcan (same arm, trajectory and gains: test_hil_tracking.py)
SLCAN_MAX, SLCAN_RMS = 3 * 0.0315, 3 * 0.0068


def test_three_joints_over_slcan_track_their_trajectory(tmp_path, hil_sim):
    """The adapter's acknowledgement lines read as nothing in python-can: a collection past its
    deadline, and the drain before each SYNC, read past them. Before they did, every TPDO
    behind an acknowledgement came a tick late: stale faults after about 1.5 s, then a joint
    ran past its limit under the hold."""
    config = variant(tmp_path, "three_joint_cia402_slcan.toml", **hil_helpers.STALL_TOLERANT)
    sim = hil_sim(config)
    assert sim.info["transport"] == "slcan"
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=4.0)
    sim_exit = sim.stop()
    check_complete(summary, telemetry, sim_exit)
    counters, tracking = summary["devices"]["arm"]["counters"], summary["tracking_error_rad"]
    print(f"CiA 402 over slcan: max {tracking['max_all']:.4f} rad, rms {tracking['rms_all']:.4f} rad, overruns "
          f"{summary['timing']['overruns']}/{summary['timing']['ticks']}, missing {counters['missing_replies']}, "
          f"late {counters['late_replies']}")
    with unless_stalled(summary):
        assert code == 0, (summary["stop_reason"], err[-2000:])
        assert counters["missing_replies"] <= 0.15 * counters["cycles"], counters  # 213 in 518 before
        assert tracking["max_all"] < SLCAN_MAX and tracking["rms_all"] < SLCAN_RMS, tracking
    assert counters["malformed_replies"] == 0 and counters["heartbeats"] > 0
    assert np.all(np.ptp(telemetry["q"], axis=0) > np.radians(15))  # it moved along the waypoints
