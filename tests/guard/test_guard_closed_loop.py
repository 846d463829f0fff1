"""The run-time guard in closed loop on the embedded PUMA 560: a test controller steps straight
into a zone, or past a joint limit. At every tick of the telemetry the robot is outside every
zone and inside its limits; it stops within the stopping distance the guard predicted, and
the guard event names the zone.

Measured here (printed by the tests): stepping into the conveyor at 1.9/4.9 rad/s (shoulder/
elbow), the hold stops the arm after 0.14 rad of the 0.73 rad predicted at 17.5 rad/s²;
the wrist bend past its limit at 5.4 rad/s, 0.11 of 0.83 rad.
"""
import numpy as np
import pytest

from guard_helpers import depths, guard_events, guard_section, rtctl_run, sim_config, step_controller, travel_after
from rtctl.model import load_robot
from guard_helpers import PUMA

INTO_CONVEYOR = [0.0, 1.5708, -2.0944, 0.0, 0.7854, 0.0]  # shoulder 90°, elbow −120°: inside the zone
PAST_WRIST_LIMIT = [0.0, 0.7854, -3.1416, 0.0, 2.6, 0.0]  # wrist bend 149° (limit 100°)


def check_outside_everywhere(config, telemetry):
    model = load_robot(PUMA)
    q = telemetry["q"]
    assert np.all(depths(config, q) > 0), "the robot was inside a zone"
    assert np.all((q >= model.q_min) & (q <= model.q_max)), "the robot was past a limit"


@pytest.mark.parametrize("target, zone", [(INTO_CONVEYOR, "overhead_conveyor"),
                                          (PAST_WRIST_LIMIT, "wrist_bend upper limit")])
def test_a_step_into_a_zone_or_past_a_limit_is_stopped_short(write, tmp_path, target, zone):
    config = write(sim_config(step_controller(target), guard_section("stop")))
    code, summary, telemetry, err = rtctl_run(config, tmp_path, "--duration", 1.5)
    assert code == 3, err[-2000:]
    (event,) = guard_events(summary)
    assert event["zone"] == zone and event["action"] == "stop"
    fault = summary["safety"]["faults"][0]
    assert fault["kind"] == "guard" and zone in fault["reason"]
    check_outside_everywhere(config, telemetry)
    travelled, predicted = travel_after(telemetry, event)
    print(f"{zone}: at {np.round(event['qd'], 2)} rad/s stopped after {travelled:.3f} of {predicted:.3f} rad predicted")
    assert max(np.abs(event["qd"])) > 1.0  # it was really going for it
    assert travelled <= predicted


def test_clamp_lets_a_slow_approach_slide_along_the_zone(write, tmp_path):
    slow = step_controller(INTO_CONVEYOR, kp=(60.0, 60.0, 60.0, 50.0, 50.0, 50.0), kd=(60.0, 60.0, 60.0, 5.0, 5.0, 5.0))
    config = write(sim_config(slow, guard_section("clamp")))
    code, summary, telemetry, err = rtctl_run(config, tmp_path, "--duration", 3.0)
    assert code == 0, (summary["safety"]["faults"], err[-2000:])
    (event,) = guard_events(summary)  # one episode: the clamp held it at the zone
    assert event["zone"] == "overhead_conveyor" and event["action"] == "clamp"
    check_outside_everywhere(config, telemetry)
    d = depths(config, telemetry["q"])
    g = np.radians(0.5)
    print(f"clamp: closest approach {np.degrees(d.min()):.3f}° (guard margin 0.5°)")
    assert d.min() > 0.5 * g  # it stayed in the outer half of the guard margin
    assert d[-1] < 2 * g  # …and leans on the zone, where the controller pushes it
