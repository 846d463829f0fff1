"""The simulated camera counts the PAL field boundaries its caller stepped over (a free-running
hil-sim stalled): stepping from field a to field b misses the b − a − 1 fields between them."""
import numpy as np
import pytest

from hil_sim.camera import FIELD_NS
from rtctl.hal.framegrabber import GrabberSettings
from vision_rig import Rig


@pytest.mark.parametrize("visited", [[0, 1, 2, 3], [0, 2], [0, 1, 5, 6, 9], [3, 4, 20]])
def test_missed_fields_are_the_boundaries_stepped_over(visited):
    rig = Rig(GrabberSettings(density=64, scan="fields"), ticks_per_field=1)
    for k in visited:
        rig.camera.step(k * FIELD_NS + FIELD_NS // 3)  # somewhere inside field k
    assert rig.camera.missed_fields == int(np.sum(np.diff(visited) - 1))
