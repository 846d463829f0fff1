"""HIL: the run-time guard over socketcand. `hil-sim` plays the PUMA 560 and its MIT drives in
its own process; a test controller steps straight into the overhead conveyor, or past the wrist
bend's limit. The guard stops it short, the event names the zone (or the limit), the robot is
outside every zone and inside its limits at every tick, the drives end out of motor mode."""
import sys

import numpy as np
import pytest

from hil_helpers import ROOT, STALL_TOLERANT, variant

sys.path.insert(0, str(ROOT / "tests" / "guard"))
from guard_helpers import PUMA, depths, guard_events, guard_section, rtctl_run, travel_after  # noqa: E402
from rtctl.model import load_robot  # noqa: E402

pytestmark = pytest.mark.hil

INTO_CONVEYOR = [0.0, 1.0472, -0.6981, 0.0, 0.0, 0.0]  # from q = 0: shoulder 60°, elbow −40°, inside the zone
PAST_WRIST_LIMIT = [0.0, 0.0, 0.0, 0.0, 2.6, 0.0]  # wrist bend 149° (limit 100°)


@pytest.mark.parametrize("target, zone", [(INTO_CONVEYOR, "overhead_conveyor"),
                                          (PAST_WRIST_LIMIT, "wrist_bend upper limit")])
def test_a_step_into_a_zone_or_past_a_limit_over_socketcand_is_stopped_short(tmp_path, hil_sim, target, zone):
    config = variant(tmp_path, "puma560_hil_socketcand.toml", **STALL_TOLERANT)
    text = config.read_text().replace('type = "computed_torque"', 'type = "step_into"')
    text = text.replace("kd = 40.0", f"kd = 40.0\ntarget = {target}\nat = 0.2", 1)
    text = text[:text.index("[trajectory]")] + text[text.index("[safety]"):]  # it holds q = 0 until the step
    config.write_text(text + guard_section("stop"))
    sim = hil_sim(config, "--port", 0)
    code, summary, telemetry, err = rtctl_run(config, tmp_path, "--duration", 2.0, env=sim.env())
    sim_exit = sim.stop()
    assert code == 3, err[-3000:]
    assert not any(d["enabled"] for d in sim_exit["drives"]), "a drive was left in motor mode"
    (event,) = guard_events(summary)
    assert event["zone"] == zone and event["action"] == "stop"
    q, model = telemetry["q"], load_robot(PUMA)
    assert np.all(depths(config, q) > 0), "the robot was inside a zone"
    assert np.all((q >= model.q_min) & (q <= model.q_max)), "the robot was past a limit"
    travelled, predicted = travel_after(telemetry, event)
    print(f"HIL guard, {zone}: at {np.round(event['qd'], 2)} rad/s stopped after {travelled:.3f} of {predicted:.3f} rad")
    assert max(np.abs(event["qd"])) > 0.5
    assert travelled <= predicted
