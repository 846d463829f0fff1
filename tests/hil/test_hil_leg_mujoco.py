"""The leg on MuJoCo over HIL: ``hil-sim --engine mujoco`` serves the leg board on the
contact-physics leg behind a pty; rtctl run walks it through the serial driver."""
import pytest

from hil_helpers import run, unless_stalled
from test_hil_leg import PATTERN, leg_variant, states

pytest.importorskip("mujoco", reason="the `mujoco` extra is not installed")


def leg_hil_guard(tmp_path):
    """configs/leg_hil.toml at 250 Hz (as the scripted leg's HIL test: the machine is shared) with
    configs/leg_mujoco.toml's circuit — the guard semantics and K_d2's 6° band; the exact circuit
    does not walk on MuJoCo (docs/mujoco.md)."""
    path = leg_variant(tmp_path)
    text = path.read_text().replace("/leg/table3.toml\"", "/leg/table3.toml\"\nsemantics = \"guard\"")
    path.write_text(text.replace("threshold = 25.0, hysteresis = 2.0", "threshold = 25.0, hysteresis = 6.0"))
    return path


@pytest.mark.hil
@pytest.mark.slow
@pytest.mark.parametrize("cycles", [5, pytest.param(20, marks=pytest.mark.soak)])
def test_the_mujoco_leg_walks_over_the_pty(hil_sim, tmp_path, cycles):
    config = leg_hil_guard(tmp_path)
    sim = hil_sim(config, "--engine", "mujoco")
    assert sim.info["transport"] == "serial"
    code, summary, tel, err = run(config, tmp_path, sim.env(), duration=1.5 * cycles, timeout=240)
    exit_event = sim.stop()
    assert exit_event["commands"] > 0 and exit_event["plant_time"] > 0, exit_event  # the pty's board did walk
    faults = summary["safety"]["faults"]
    if faults:  # a stalled machine starves the board: from the safety stop on, the joints are locked, not walking
        keep = tel["t"] < faults[0]["t"]
        tel = {"leg_state": tel["leg_state"][keep]}
    seq = states(tel)
    good = 0
    while good < len(seq) and seq[good] == PATTERN[good % 8]:
        good += 1
    assert good == len(seq), seq  # whatever the machine does: never a wrong state while it walks
    with unless_stalled(summary):
        assert code == 0, err[-2000:]
        assert (len(seq) - 1) // 8 >= cycles, f"{len(seq)} states, plant time {exit_event['plant_time']:.1f} s"
    print(f"\nMuJoCo leg over the pty: {len(seq)} states, {(len(seq) - 1) // 8} complete cycles, plant time "
          f"{exit_event['plant_time']:.1f} s, {exit_event['commands']} commands, no missing or extra state")
