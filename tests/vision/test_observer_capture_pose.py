"""The marker observer predicts the marker from the joint positions at the image's capture
time, interpolated linearly between the two ticks around it: on a motion linear between ticks
that is the exact pose at that instant — not the tick before, not the tick after. And the marker search
finds nothing in a box whose contrast (brightest − mean) is below ``min_contrast``, however
bright the box (rtctl/vision/marker.py)."""
import numpy as np
import pytest

from rtctl.control.base import Reference
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.hal.joints import JointCommand, JointState
from rtctl.model import kinematics, load_robot
from rtctl.vision.marker import locate
from rtctl.vision.pixels import unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, READY

RATE = np.radians([20, -10, 15, 30, -25, 40])  # rad/s: a motion linear in time


class _NoImage:
    def grab(self):
        return None


# between ticks 2 and 3, and 3 and 4 (the newest two rows, where the joints have stopped: a pose
# extrapolated from the rows before shows); not at ½, where the two weights are equal
@pytest.mark.parametrize("between, fraction", [(2, 0.25), (2, 0.8), (3, 0.3)])
def test_the_prediction_uses_the_pose_at_the_capture_time_between_two_ticks(between, fraction):
    from rtctl.vision.observer import MarkerObserver

    model = load_robot(PUMA)
    observer = MarkerObserver("marker", model, CAMERA)
    observer.grabber = _NoImage()
    state, ref, command = JointState(6), Reference(6), JointCommand(6)
    state.position[:] = READY
    observer.reset(state)
    period = 0.020  # ticks far apart (a PAL field): a tick's worth of motion is pixels
    for k in range(5):
        state.position[:] = READY + RATE * min(k, 3) * period  # the joints stop at tick 3
        observer.update(k * period, state, ref, command)
    capture = (between + fraction) * period
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    blank = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    observer.observe(Frame(1, capture, "frame", settings, blank, unpack))
    expected = CAMERA.project(kinematics.fk(model, READY + RATE * min(capture, 3 * period))[:3, 3])
    np.testing.assert_allclose(observer.internals["marker_predicted_px"], expected, atol=1e-6)
    tick_before = CAMERA.project(kinematics.fk(model, READY + RATE * 2 * period)[:3, 3])
    tick_after = CAMERA.project(kinematics.fk(model, READY + RATE * 3 * period)[:3, 3])
    assert np.linalg.norm(tick_after - tick_before) > 1.5  # (the motion shows: the time matters)


def test_no_marker_in_a_bright_box_of_low_contrast_and_one_in_a_dark_box():
    out = np.zeros(4)
    box = np.full((21, 21), 200, dtype=np.uint8)
    box[9:12, 9:12] = 230  # 30 levels above a bright background: 0.12 of full scale
    assert not locate(box, (10.0, 10.0), (10, 10), 256, 0.2, out)
    dark = np.full((21, 21), 10, dtype=np.uint8)
    dark[9:12, 9:12] = 230
    assert locate(dark, (10.0, 10.0), (10, 10), 256, 0.2, out)
    np.testing.assert_allclose(out[:2], [10.0, 10.0])  # the blob's centre


def test_an_image_captured_at_a_ticks_own_time_gets_that_ticks_positions_exactly():
    """In lock-step a capture is stamped with a tick's time: the pose is that tick's measured
    positions, bit for bit — not an interpolation that ends on it (q_k − q_{k−1}) · 1 + q_{k−1},
    which rounds."""
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    observer.grabber = _NoImage()
    state, ref, command = JointState(6), Reference(6), JointCommand(6)
    state.position[:] = READY
    observer.reset(state)
    # (rows of alternating magnitude: there the difference rounds, and adding back does not undo it)
    rows = np.random.default_rng(4).uniform(-2.0, 2.0, (8, 6)) * np.where(np.arange(8)[:, None] % 2, 1e-3, 1.0)
    for k, q in enumerate(rows):
        state.position[:] = q
        observer.update(k * 0.004, state, ref, command)
    for k in range(1, 8):  # (row 7 the newest)
        observer._positions_at(k * 0.004)
        np.testing.assert_array_equal(observer._q_at, rows[k])
