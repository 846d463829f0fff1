"""``move.times`` are the arrival times of the waypoints: seconds > 0, strictly increasing — two
waypoints at the same time would need an infinite speed between them, so equal times are
refused at validation, before a move is planned."""
import pytest

from rtctl.control_socket.requests import InvalidRequest, validate


def _move(times):
    return {"cmd": "move", "waypoints": [[0.0, 0.0], [0.1, 0.0], [0.2, 0.1]], "times": times}


@pytest.mark.parametrize("times", [[1.0, 1.0, 2.0], [1.0, 2.0, 2.0], [0.5, 0.5, 0.5], [0.0, 1.0, 2.0],
                                   [-1.0, 1.0, 2.0], [1.0, 3.0, 2.0]])
def test_times_that_are_not_positive_and_strictly_increasing_are_refused(times):
    with pytest.raises(InvalidRequest, match="strictly increasing"):
        validate(_move(times), 2)


def test_strictly_increasing_positive_times_are_taken():
    assert validate(_move([0.5, 1.0, 1.0 + 1e-9]), 2)["times"].tolist() == [0.5, 1.0, 1.0 + 1e-9]
