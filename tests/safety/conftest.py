import pytest

from safety_rig import Rig


@pytest.fixture
def rig():
    return Rig(position_margin=0.1, hold_stiffness=100.0, damping=4.0)
