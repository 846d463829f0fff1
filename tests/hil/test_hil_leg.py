"""The prosthetic leg over HIL: hil-sim plays the leg board and plant behind a pty, rtctl run
drives it through the serial driver and codec (configs/leg_hil.toml)."""
import numpy as np
import pytest

from hil_helpers import CONFIGS, run, unless_stalled, variant

PATTERN = (1, 2, 3, 4, 1, 5, 1, 6)


def states(tel) -> list[int]:
    s = tel["leg_state"].ravel()
    return [int(s[0])] + [int(s[i]) for i in np.flatnonzero(np.diff(s)) + 1]


def leg_variant(tmp_path):
    """configs/leg_hil.toml at 250 Hz (the plant steps one period per command), table path absolute."""
    path = variant(tmp_path, "leg_hil.toml", rate_hz="250.0")
    path.write_text(path.read_text().replace('table = "leg/table3.toml"', f'table = "{CONFIGS}/leg/table3.toml"'))
    return path


@pytest.mark.hil
@pytest.mark.slow
@pytest.mark.parametrize("cycles", [5, pytest.param(20, marks=pytest.mark.soak)])
def test_the_leg_walks_over_the_pty_for_its_cycles(hil_sim, tmp_path, cycles):
    config = leg_variant(tmp_path)
    sim = hil_sim(config)
    assert sim.info["transport"] == "serial" and "HIL_SIM_TTY" in sim.info["env"]
    code, summary, tel, err = run(config, tmp_path, sim.env(), duration=2.25 * cycles, timeout=240)
    exit_event = sim.stop()
    seq = states(tel)
    good = 0
    while good < len(seq) and seq[good] == PATTERN[good % 8]:
        good += 1
    assert good == len(seq), seq  # whatever the machine does: never a wrong state
    board = summary["devices"]["board"]
    assert board["crc_errors"] == 0 and board["frames"] >= exit_event["commands"] - 5
    with unless_stalled(summary):  # a stalled machine can trip the overrun limit before 20 cycles
        assert code == 0, err[-2000:]
        assert (len(seq) - 1) // 8 >= cycles, f"{len(seq)} states, plant time {exit_event['plant_time']:.1f} s"


@pytest.mark.hil
@pytest.mark.parametrize("fault, kind", [("drop@600", "device_error"), ("silent:1@600", "stale")])
def test_a_closed_pty_or_a_silent_board_locks_the_leg_and_exits_3(hil_sim, tmp_path, fault, kind):
    """After 600 commands (2.4 s) the pty closes, or the board stops answering: the loop sees
    a device error, or stale joints for stale_ticks (5) ticks, and locks both joints."""
    config = leg_variant(tmp_path)
    sim = hil_sim(config, "--fault", fault)
    code, summary, tel, err = run(config, tmp_path, sim.env(), duration=20.0, timeout=120)
    assert code == 3, err[-2000:]
    faults = summary["safety"]["faults"]
    with unless_stalled(summary):  # (an overrun limit reached first is an e-stop)
        assert faults and faults[0]["kind"] == kind, faults
    tick = faults[0]["tick"]
    actions = tel["leg_actions"]
    rows = np.flatnonzero(tel["t"] >= faults[0]["t"])
    assert rows.size and np.all(actions[rows] == 0), "both joints locked from the fault's tick on"
    if kind == "stale":  # exactly stale_ticks ticks after the board's last frame (never retried)
        # the sensors are noisy: every frame changes the channels, a silent board leaves them as they were
        new_frame = np.flatnonzero(np.any(np.diff(tel["leg_channels"], axis=0) != 0, axis=1)) + 1
        last_frame = new_frame[new_frame < rows[0]][-1]
        assert rows[0] - last_frame == 5, (int(rows[0]), int(last_frame))
    assert tick > 0 and summary["exit_code"] == 3
