"""Defect 2: `move` with `times` is honoured or refused with the reason, never half-applied."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.control_socket import request
from rtctl.errors import TrajectoryError
from rtctl.trajectory import JointLimits, retarget
from runtime_helpers import BASE, rtctl

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

# on the wall clock, at a rate a loaded test machine keeps and no overrun stop (timing is not what
# is tested here); no [trajectory]: the arm holds HOME until the move, however late its reply comes
# (with a trajectory it had moved 4–6° away while the planner compiled its kernels from cold)
PACED = BASE[:BASE.index("[trajectory]")].replace("realtime_factor = 0.0", "realtime_factor = 1.0").replace(
    "rate_hz = 1000.0", "rate_hz = 250.0\noverrun_limit = 1000000")
HOME = [0.0, 45.0, -180.0, 0.0, 45.0, 0.0]
NEAR = [10.0, 40.0, -170.0, 5.0, 50.0, 5.0]


def test_defect_02_move_honours_times_or_refuses_them(write_config, daemon):
    d = daemon(write_config(PACED))
    d.wait_ready()
    # a slow move: it used to finish in 0.48 s whatever the times said. A move is answered once
    # planned, the first one once the planner process has loaded its kernels too: on a busy
    # machine that is seconds, so the client waits as `rtctl move` does (120 s), not 5 s
    slow = request(d.socket, "move", waypoints=[NEAR, HOME, NEAR], times=[40.0, 70.0, 100.0], deg=True, timeout=120)
    assert slow["ok"], slow
    assert slow["t_end"] - slow["t_start"] == pytest.approx(100.0)
    status = request(d.socket, "status")
    q_des = np.degrees(status["q_des"])
    assert np.max(np.abs(q_des - HOME)) < 1.0  # 40 s to the first waypoint: barely started

    too_fast = request(d.socket, "move", waypoints=[NEAR, HOME], times=[5.0, 5.01], deg=True, timeout=120)
    assert not too_fast["ok"] and "limits" in too_fast["error"], too_fast
    first_too_fast = request(d.socket, "move", waypoints=[NEAR], times=[0.01], deg=True, timeout=120)
    assert not first_too_fast["ok"] and "violates the limits" in first_too_fast["error"], first_too_fast
    # a refused move changes nothing: the slow one still runs to its end
    after = request(d.socket, "status")
    assert np.max(np.abs(np.degrees(after["q_des"]) - HOME)) < 1.0
    assert rtctl("stop", "--socket", d.socket).returncode == 0
    assert d.finish()[0] == 0


def test_defect_02_retarget_times_every_waypoint():
    limits = JointLimits(np.full(2, 1.0), np.full(2, 2.0), np.full(2, -3.0), np.full(2, 3.0))
    q0 = np.zeros(2)
    traj = retarget(1.0, q0, q0, q0, [[1.0, 0.5], [1.0, 0.5], [0.0, 1.0]], limits, duration=4.0,
                    durations=[2.0, 5.0])
    assert traj.t_end == pytest.approx(1.0 + 4.0 + 2.0 + 5.0)
    for t, point in ((5.0, [1.0, 0.5]), (7.0, [1.0, 0.5]), (12.0, [0.0, 1.0])):
        np.testing.assert_allclose(traj.state_at(t)[0], point, atol=1e-12)
    with pytest.raises(TrajectoryError, match="below"):
        retarget(0.0, q0, q0, q0, [[1.0, 0.5], [0.0, 1.0]], limits, duration=4.0, durations=[0.1])
