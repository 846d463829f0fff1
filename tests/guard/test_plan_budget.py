"""A zone over three joints while other joints move too (issue 26, item 2): the grid's goal test
compares the zone's joints only, every plan ends within its budget with a path or "no path" and
the reason, and `plan --deg` answers in degrees (item 12). Subprocess timeouts only catch hangs."""
import re

import numpy as np
import pytest

from guard_helpers import ROOT, rtctl
from rtctl.config import load_config
from rtctl.guard import Box, Scene, Zone, path_violation, plan_path

FROM = ["0", "45", "-180", "0", "45", "0"]
TO = ["10", "45", "-180", "0", "30", "0"]
WRIST_BOX = """
[[guard.zones]]
name = "wrist_box"
joints = ["wrist_roll", "wrist_bend", "flange"]
lo = [-20, 36, -20]
hi = [20, 40, 20]
"""


def cage(centre=(60.0, 0.0, 60.0), inner=10.0, wall=4.0) -> str:
    """A closed hollow box in (wrist_roll, wrist_bend, flange), degrees: six slabs."""
    c = np.array(centre)
    parts = []
    for axis in range(3):
        for side in (-1, 1):
            lo, hi = c - inner - wall, c + inner + wall
            if side < 0:
                hi[axis] = c[axis] - inner
            else:
                lo[axis] = c[axis] + inner
            parts.append(f'[[guard.zones.parts]]\njoints = ["wrist_roll", "wrist_bend", "flange"]\n'
                         f"lo = {lo.tolist()}\nhi = {hi.tolist()}\n")
    return '\n[[guard.zones]]\nname = "cage"\n' + "\n".join(parts)


def guard_config(tmp_path, zones: str, guard_extra: str = "", trajectory: str = ""):
    """The shipped guard cell (configs/puma560_guard_sim.toml) with more zones and settings."""
    text = (ROOT / "configs" / "puma560_guard_sim.toml").read_text()
    text = text.replace('description = "robots/', f'description = "{ROOT}/configs/robots/')
    text = text.replace('path = "../runs/puma560_guard_sim.msgpack"', f'path = "{tmp_path}/run.msgpack"')
    text = text.replace("resolution = 2.0 ", f"{guard_extra}\nresolution = 2.0 ")
    if trajectory:
        text = re.sub(r"\[trajectory\]\n.*?\n\n", trajectory, text, flags=re.S)
    path = tmp_path / "wrist.toml"
    path.write_text(text + zones)
    return path


def test_a_three_joint_zone_is_bypassed_while_the_waist_moves_too(tmp_path):
    cfg = load_config(guard_config(tmp_path, WRIST_BOX))
    q0, q1 = np.radians(np.array(FROM, float)), np.radians(np.array(TO, float))
    plan = plan_path(cfg.guard.scene, q0, q1, resolution=cfg.guard.resolution, max_nodes=cfg.guard.plan_budget)
    assert plan.found and plan.method == "grid", plan.reason
    assert plan.crossing.what == "wrist_box"
    assert np.array_equal(plan.path[0], q0) and np.array_equal(plan.path[-1], q1)
    assert path_violation(cfg.guard.scene, plan.path) is None
    assert plan.expanded < 2000  # within a `move`'s default budget too


def test_the_issue_command_answers_with_a_path(tmp_path):
    path = guard_config(tmp_path, WRIST_BOX)
    result = rtctl("plan", path, "--from", *FROM, "--to", *TO, "--deg", timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "path (grid" in result.stdout


def test_check_plans_a_trajectory_across_the_three_joint_zone(tmp_path):
    trajectory = f"""[trajectory]
unit = "deg"
waypoints = [[{", ".join(TO)}]]

"""
    path = guard_config(tmp_path, WRIST_BOX, trajectory=trajectory)
    result = rtctl("check", path, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "enters zone 'wrist_box'" in result.stdout and "bypass (grid" in result.stdout


def _shown(line: str) -> list[float]:
    return [float(x) for x in re.search(r"q = \[([^\]]*)\]", line).group(1).split(",")]


def test_plan_deg_reports_the_crossing_and_a_refused_target_in_degrees(tmp_path):
    path = guard_config(tmp_path, WRIST_BOX)
    result = rtctl("plan", path, "--from", *FROM, "--to", *TO, "--deg", timeout=120)
    line = next(x for x in result.stdout.splitlines() if "enters zone 'wrist_box'" in x)
    # the straight path meets the box's face wrist_bend = 40 a third of the way from 45 to 30
    want = np.array(FROM, float) + (np.array(TO, float) - np.array(FROM, float)) / 3
    assert np.allclose(_shown(line), want, atol=1e-3) and line.rstrip().endswith("deg"), line
    assert " rad" not in result.stdout, result.stdout  # lengths too
    inside = ["10", "45", "-180", "0", "38", "0"]
    refused = rtctl("plan", path, "--from", *FROM, "--to", *inside, "--deg", timeout=120)
    assert refused.returncode == 2
    assert np.allclose(_shown(refused.stdout), np.array(inside, float)), refused.stdout


def test_an_enclosed_target_ends_with_no_path_and_the_reason_within_the_default_budget(tmp_path):
    path = guard_config(tmp_path, cage())
    result = rtctl("plan", path, "--from", *FROM, "--to", "10", "45", "-180", "60", "0", "60", "--deg", timeout=180)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "no path" in result.stdout and "search budget (100000 grid nodes)" in result.stdout, result.stdout
    assert "(wrist_roll, wrist_bend, flange)" in result.stdout


@pytest.mark.parametrize("start, target, words", [
    (FROM, ["10", "45", "-180", "60", "0", "60"], "search budget (3000 grid nodes)"),  # the target caged
    (["10", "45", "-180", "60", "0", "60"], FROM, "no path at resolution"),  # the start caged: exhausted
])
def test_no_path_names_why_within_a_configured_budget(tmp_path, start, target, words):
    path = guard_config(tmp_path, cage(), guard_extra="plan_budget = 3000")
    result = rtctl("plan", path, "--from", *start, "--to", *target, "--deg", timeout=120)
    assert result.returncode == 2 and "no path" in result.stdout and words in result.stdout, result.stdout


def test_plan_budget_must_be_a_positive_count(tmp_path):
    result = rtctl("check", guard_config(tmp_path, WRIST_BOX, guard_extra="plan_budget = 0"), timeout=120)
    assert result.returncode == 2 and "guard.plan_budget" in result.stderr, result.stderr


def test_the_grid_compares_only_its_joints_with_the_goal():
    """Four joints, the zone over the first three; joint 3 moves as well."""
    box = Zone("box", [Box((0, 1, 2), [-0.2, -0.2, -0.2], [0.2, 0.2, 0.2])])
    scene = Scene([box], [-1.0] * 4, [1.0] * 4, margin=0.05)
    plan = plan_path(scene, [-0.5, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.7], resolution=0.1, max_nodes=5000)
    assert plan.found and plan.method == "grid", plan.reason
    assert path_violation(scene, plan.path) is None and plan.path[-1][3] == 0.7
