"""Issue 26 item 12: a `move --deg` that is refused answers in degrees, as it was asked."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from rtctl.config import load_config
from rtctl.errors import RtctlError
from rtctl.moves.plan import Start, plan_move
from rtctl.trajectory import JointLimits

GUARD = Path(__file__).resolve().parents[2] / "configs" / "puma560_guard_sim.toml"
INSIDE_DEG = [0.0, 90.0, -120.0, 0.0, 0.0, 0.0]  # inside the overhead conveyor's zone


@pytest.mark.parametrize("deg", [True, False])
def test_a_refused_target_is_shown_in_the_unit_asked(deg):
    cfg = load_config(GUARD, sim=True)
    limits = JointLimits.for_run(cfg.model, cfg.trajectory)
    home = np.radians([0, 45, -180, 0, 45, 0])
    target = INSIDE_DEG if deg else np.radians(INSIDE_DEG).tolist()
    req = {"q": target, "waypoints": None, "times": None, "duration": None, "deg": deg}
    with pytest.raises(RtctlError) as e:
        plan_move(cfg, limits, 0.0, Start(home, np.zeros(6), np.zeros(6)), req)
    message = str(e.value)
    shown = [float(x) for x in re.search(r"q = \[([^\]]*)\]", message).group(1).split(",")]
    assert "overhead_conveyor" in message
    np.testing.assert_allclose(shown, target, atol=1e-3)
    assert message.rstrip().split("q = ")[1].split("]")[1].strip().startswith("deg") == deg, message
