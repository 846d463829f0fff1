"""A move's ``deg`` scales the angles of revolute joints only: a prismatic joint's value is
metres, in a move as in the robot file (whose ``angle_unit = "deg"`` leaves lengths alone). So
the file's own limits, sent as a move in degrees, are the loaded model's limits."""
import numpy as np

from rtctl.model import PRISMATIC, REVOLUTE, load_robot
from rtctl.moves.plan import targets

ROBOT = """
name = "waist_and_slide"
angle_unit = "deg"
[[joints]]
name = "waist"
type = "revolute"
alpha = 0
a = 0
d = 0.4
q_min = -170
q_max = 170
mass = 1.0
[[joints]]
name = "slide"
type = "prismatic"
alpha = 0
a = 0
d = 0
q_min = 0.05
q_max = 0.8
mass = 1.0
"""


def test_deg_scales_revolute_joints_and_leaves_prismatic_ones_in_metres(tmp_path):
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    model = load_robot(path)
    assert list(model.joint_types) == [REVOLUTE, PRISMATIC]
    np.testing.assert_allclose(targets(model, {"q": [90.0, 0.5], "deg": True}), [[np.pi / 2, 0.5]])
    np.testing.assert_allclose(targets(model, {"q": [0.3, 0.5], "deg": False}), [[0.3, 0.5]])
    file_limits = [[-170.0, 0.05], [170.0, 0.8]]  # as written in the file
    np.testing.assert_allclose(targets(model, {"waypoints": file_limits, "deg": True}),
                               [model.q_min, model.q_max], rtol=1e-15)
