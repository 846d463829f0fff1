import pytest

from rtctl.trajectory import JointLimits


@pytest.fixture
def limits3():
    return JointLimits(v_max=[1.0, 2.0, 3.0], a_max=[2.0, 4.0, 5.0], q_min=[-3.0] * 3, q_max=[3.0] * 3)
