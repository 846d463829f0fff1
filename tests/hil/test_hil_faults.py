"""HIL faults, each ending in a controlled state: a drive falls silent, the loop freezes, the
socketcand connection drops, replies arrive corrupted. In every case the telemetry holds every
tick and hil-sim reports every drive out of motor mode at the end."""

import numpy as np
import pytest

from hil_helpers import STALL_TOLERANT, check_reopened_and_stopped, run, run_with_a_frozen_loop, unless_stalled, variant

pytestmark = pytest.mark.hil

# the stale-data test keeps the shipped 3 ticks, with a 100 ms watchdog; its fault comes at
# command set 100 (0.2 s), so that a stall of this VM before it (hil_helpers.STALL_TOLERANT) is
# unlikely to stop the run first (at 500 it did, 1 suite run in 10)
TOLERANT = {"drive_timeout": 0.1}


def check_complete(summary, telemetry, sim_exit):
    assert telemetry.rows == summary["timing"]["ticks"] == summary["telemetry"]["rows"]
    assert not any(d["enabled"] for d in sim_exit["drives"]), "a drive was left in motor mode"


def test_a_silent_drive_is_a_safe_stop_within_3_ticks(tmp_path, hil_sim):
    config = variant(tmp_path, "puma560_hil_socketcand.toml", **TOLERANT)
    sim = hil_sim(config, "--port", 0, "--drive-timeout-ms", 100, "--fault", "silent:3@100")
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=6.0)
    sim_exit = sim.stop()
    assert code == 3, err[-3000:]
    check_complete(summary, telemetry, sim_exit)
    (silenced,) = sim.of("fault")
    assert silenced["kind"] == "silent" and silenced["drive"] == 3
    stale = [e for e in summary["devices"]["arm"]["events"] if e["event"] == "stale"][0]
    faults = summary["safety"]["faults"]
    first = faults[0]
    at_first = {(f["kind"], f["joint"]) for f in faults if f["tick"] == first["tick"]}
    # the same tick: the device reports ERROR (its stale limit) and the safety stage's own
    # stale-data watchdog flags the elbow (joint 2, drive 3)
    assert {("device_error", 0), ("stale", 2)} <= at_first, faults
    # the first command drive 3 left unanswered went out in the tick at missing_since; the
    # safety stage took over (fallback) on the third tick after it (ticks counted in the
    # telemetry: the loop's time also counts the periods it skipped when late)
    after = np.count_nonzero((telemetry["t"] > stale["missing_since"]) & (telemetry["t"] <= first["t"]))
    assert after == 3, (first, stale)
    print(f"silent drive: fallback {after} ticks after its first unanswered command, "
          f"{first['t'] - stale['missing_since']:.3f} s loop time")
    assert stale["t"] == pytest.approx(first["t"])
    assert summary["safety"]["deactivated"]
    # drive 3 heard nothing more (silent) and its own watchdog turned it off; the others heard exit motor mode
    offs = {e["drive"]: e["cause"] for e in sim.of("motor_off")}
    assert offs[3] == "watchdog" and all(offs[i] == "command" for i in (1, 2, 4, 5, 6)), offs


def test_a_frozen_loop_lets_the_drive_watchdogs_turn_the_motors_off(tmp_path, hil_sim):
    config = variant(tmp_path, "puma560_hil_socketcand.toml")  # the drives' 20 ms watchdog
    sim = hil_sim(config, "--port", 0)
    code, summary, telemetry, err = run_with_a_frozen_loop(config, tmp_path, sim.info["env"])
    sim_exit = sim.stop()
    offs = [e for e in sim.of("motor_off") if e["cause"] == "watchdog"]
    assert sorted(e["drive"] for e in offs) == [1, 2, 3, 4, 5, 6], sim.events
    # each drive cut its motor 20 ms after its last command, as measured on its own clock
    # (measured 20.1-23 ms: the rest is the simulator's wake-up lateness on this shared machine)
    late = [e["since_command_ms"] for e in offs]
    print(f"drive watchdog: motors off {min(late):.1f}-{max(late):.1f} ms after the last command")
    assert all(20.0 <= ms <= 30.0 for ms in late), late
    # the loop noticed the pause on resuming: its drives are off, so the device asked to be
    # stopped (a category-1 stop) and the daemon exited with a fault
    assert code == 3, err[-3000:]
    assert any(e["event"] == "drives_off" for e in summary["devices"]["arm"]["events"])
    check_complete(summary, telemetry, sim_exit)


def test_a_dropped_connection_is_reopened_and_stopped_safely_within_2_s(tmp_path, hil_sim):
    config = variant(tmp_path, "puma560_hil_socketcand.toml")
    sim = hil_sim(config, "--port", 0, "--fault", "drop@100")
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=6.0)
    sim_exit = sim.stop()
    assert code == 3, err[-3000:]
    check_complete(summary, telemetry, sim_exit)
    # from the loss of the link to the drives off: measured ~0.55 s (reopen within 50 ms, the
    # drives had stopped on their watchdog: a category-1 stop of estop_off_delay = 0.5 s)
    check_reopened_and_stopped(summary)
    assert sim_exit["server"]["connections"] >= 2


def test_corrupted_replies_are_counted_and_ignored(tmp_path, hil_sim):
    config = variant(tmp_path, "puma560_hil_socketcand.toml", **STALL_TOLERANT)
    sim = hil_sim(config, "--port", 0, "--fault", "corrupt:2:0.02")
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=3.0)
    sim_exit = sim.stop()
    check_complete(summary, telemetry, sim_exit)
    with unless_stalled(summary):
        assert code == 0, (summary["stop_reason"], summary["safety"]["faults"][:3], err[-1000:])
        assert summary["tracking_error_rad"]["max_all"] < 0.15
    corrupted = {d["drive"]: d["counters"]["corrupted"] for d in sim_exit["drives"]}
    assert corrupted[2] > 10 and sum(corrupted.values()) == corrupted[2]
    assert summary["devices"]["arm"]["counters"]["malformed_replies"] == corrupted[2]
    assert np.all(np.isfinite(telemetry["q"]))
