"""Bad zones and infeasible starts or waypoints exit 2 before any device is touched, naming the
file, the key and the zone."""
import pytest

from guard_helpers import PUMA, guard_section, rtctl, sim_config
from rtctl.cli import main

CT = """
[[controllers]]
name = "ct"
type = "computed_torque"
kp = 400.0
kd = 40.0
"""
GOOD = sim_config(CT, guard_section())


def zone(body: str, name="bad zone") -> str:
    return GOOD + f'\n[[guard.zones]]\nname = "{name}"\n{body}\n'


@pytest.mark.parametrize("text, key, words", [
    (zone('joints = ["shoulder", "elbow"]\npolygon = [[0, 0], [20, 0], [10, 5], [10, 20]]'),
     "guard.zones[1].polygon", ["'bad zone'", "not convex"]),
    (zone('joints = ["shoulder", "elbow"]\npolygon = [[0, 0], [10, 10], [20, 20]]'),
     "guard.zones[1].polygon", ["'bad zone'", "no area"]),
    (zone('joints = [1, 7]\npolygon = [[0, 0], [10, 0], [0, 10]]'),
     "guard.zones[1].joints", ["'bad zone'", "joint index 7 out of range"]),
    (zone('joints = ["shoulder", "elbow", "waist"]\npolygon = [[0, 0], [10, 0], [0, 10]]'),
     "guard.zones[1].joints", ["'bad zone'", "exactly two joints"]),
    (zone('joints = ["waist"]\nlo = [10]\nhi = [5]'), "guard.zones[1].lo", ["'bad zone'", "lo < hi"]),
    (zone('joints = ["waist"]\nlo = [10]\nhi = [20]\nradius = 3'), "guard.zones[1].radius", ["unknown key"]),
    (zone('joints = ["waist"]\nlo = [10]\nhi = [20]', name="overhead_conveyor"),
     "guard.zones[1].name", ["'overhead_conveyor' is declared twice"]),
    (GOOD.replace("[guard]", "[guard]\nmargin = -1.0"), "guard.margin", ["≥ 0"]),
    (GOOD.replace("guard_margin = 0.5", "guard_margin = 2.5"), "guard.guard_margin", ["half the margin"]),
    (GOOD.replace("deceleration = 1000.0", "deceleration = nan"), "guard.deceleration", ["finite"]),
    (GOOD + '\n[trajectory]\nunit = "deg"\nwaypoints = [[0, 45, -180, 0, 45, 0], [0, 90, -120, 0, 0, 0]]\n',
     "trajectory.waypoints[1]", ["inside zone 'overhead_conveyor'"]),
    (GOOD + '\n[trajectory]\nunit = "deg"\nwaypoints = [[0, 45, -180, 0, 45, 0], [0, 90, -120, 0, 0, 0], '
            '[0, 45, -180, 0, 45, 0], [0, 90, -120, 0, 0, 0]]\n',
     "trajectory.waypoints[1]", ["also infeasible: waypoints[3] inside zone 'overhead_conveyor'"]),
    (sim_config(CT, guard_section(), initial_q="[0.0, 1.5708, -2.0944, 0.0, 0.0, 0.0]"),
     "sim.initial_q", ["inside zone 'overhead_conveyor'"]),
])
def test_check_refuses_with_exit_2_naming_the_key_and_zone(tmp_path, capsys, text, key, words):
    path = tmp_path / "run.toml"
    path.write_text(text)
    assert main(["check", str(path)]) == 2  # in-process: the same code path as the command, faster
    out, err = capsys.readouterr()
    assert str(path) in err and key in err
    assert ": OK" not in out, out  # issue 26 item 14: nothing said OK before the refusal
    for w in words:
        assert w in err


def test_a_start_inside_a_zone_refuses_to_run_with_exit_2(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text(sim_config(CT, guard_section(), initial_q="[0.0, 1.5708, -2.0944, 0.0, 0.0, 0.0]"))
    result = rtctl("run", path, "--duration", 1, "--socket", tmp_path / "s.sock")
    assert result.returncode == 2, result.stderr[-2000:]
    assert "start configuration is inside zone 'overhead_conveyor'" in result.stderr


def test_zones_in_the_robot_file_are_validated_too(tmp_path):
    robot = tmp_path / "robot.toml"
    robot.write_text(PUMA.read_text().replace("margin = 3.0", "margin = -3.0"))
    path = tmp_path / "run.toml"
    path.write_text(GOOD.replace(str(PUMA), str(robot)))
    result = rtctl("check", path)  # the command as users run it: exit 2, a message, no traceback
    assert result.returncode == 2 and str(robot) in result.stderr and "guard.margin" in result.stderr
    assert "Traceback" not in result.stderr
