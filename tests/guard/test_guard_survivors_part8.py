"""Tests for guard mutants that survived the suite (part 8; docs/mutation/guard.md): the joint limits
are closed — a segment may end exactly on a limit (a point *past* it is one beyond, as
``point_violation`` already holds) — checked at both ends of the segment, and a hair beyond
each limit is named with its joint."""
from __future__ import annotations

import numpy as np
import pytest

from rtctl.guard import Scene, point_violation, segment_violation

SCENE = Scene([], [-1.0, -2.0], [1.0, 2.0], joint_names=("shoulder", "elbow"))


@pytest.mark.parametrize("end", [[1.0, 0.0], [-1.0, 0.0], [0.0, 2.0], [0.0, -2.0], [1.0, 2.0], [-1.0, -2.0]])
@pytest.mark.parametrize("start_first", [True, False])
def test_a_segment_may_begin_or_end_exactly_on_a_limit(end, start_first):
    a, b = ([0.0, 0.0], end) if start_first else (end, [0.0, 0.0])
    assert segment_violation(SCENE, a, b) is None
    assert point_violation(SCENE, end) is None


@pytest.mark.parametrize("joint, sign, name", [(0, 1, "shoulder"), (0, -1, "shoulder"), (1, 1, "elbow"),
                                               (1, -1, "elbow")])
def test_a_segment_ending_a_hair_past_a_limit_names_the_joint(joint, sign, name):
    end = np.zeros(2)
    end[joint] = sign * np.nextafter([1.0, 2.0][joint], np.inf)
    v = segment_violation(SCENE, [0.0, 0.0], end)
    assert v is not None and v.what == f"{name} limit" and v.at == 1.0
    v = segment_violation(SCENE, end, [0.0, 0.0])
    assert v is not None and v.what == f"{name} limit" and v.at == 0.0
