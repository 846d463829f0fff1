"""Tests for vision mutants that survived the full run's fast pass (part 8; docs/mutation/vision.md):

* a frame's registers with a scan code outside the four scans are no settings (a negative code
  is not the last scan counted from the end);
* the marker's centroid weights every pixel above the threshold by how far above it is, a
  pixel 0.68 of a level above included (the module docstring), against the centroid computed
  here by hand;
* a camera's focal length defaults to 700 screen pixels (docs/framegrabber.md);
* the marker observer's warm-up leaves no trace in its telemetry: before the first image the
  measured, predicted and error pixels and the capture time are NaN, the frame number 0.
"""
import numpy as np
import pytest

from drivers.protocols.framegrabber import decode, encode
from rtctl.errors import SettingsError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.hal.joints import JointState
from rtctl.model import load_robot
from rtctl.tomltable import Table
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from runtime_helpers import PUMA
from vision_rig import CAMERA, READY

SCAN_WORD = 6  # the registers: density, density_v, x, y, width, height, scan, …


@pytest.mark.parametrize("code", [-1, -4, 4])
def test_a_scan_code_outside_the_four_scans_is_no_settings(code):
    words = encode(GrabberSettings(density=64, scan="frame"))
    assert decode(words).scan == "frame"
    words[SCAN_WORD] = code
    with pytest.raises(SettingsError, match=f"scan code {code}"):
        decode(words)


def test_the_centroid_weights_each_pixel_by_how_far_above_the_threshold_it_is():
    img = np.zeros((5, 5), dtype=np.uint8)
    img[2, 2], img[2, 3] = 10, 6
    mean = 16 / 25
    threshold = 0.5 * (10 + mean)  # halfway between the brightest pixel and the box's mean
    w = np.array([10 - threshold, 6 - threshold])
    assert 0 < w[1] < 1  # the dimmer pixel is less than a level above the threshold
    out = np.zeros(4)
    assert locate(img, (2.0, 2.0), (2, 2), 256, 0.01, out)
    np.testing.assert_allclose(out, [2.0, (2 * w[0] + 3 * w[1]) / w.sum(), w.sum(), 2], rtol=1e-12)


class _NoImages:
    def grab(self):
        return None


def test_the_observers_warm_up_leaves_its_telemetry_empty():
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    observer.grabber = _NoImages()
    state = JointState(6)
    state.position[:] = READY
    observer.reset(state)  # the first reset warms up on an image of its own
    i = observer.internals
    for name in ("marker_measured_px", "marker_predicted_px", "marker_error_px", "marker_capture_t"):
        assert np.isnan(i[name]).all(), name
    assert int(i["marker_seq"]) == 0 and observer.images == observer.found == 0


def test_a_cameras_focal_length_defaults_to_700_pixels():
    options = {"position": [1.7, -1.2, 0.9], "look_at": [0.35, 0.05, 0.0]}
    default = Camera.from_table(Table(dict(options), "camera.toml", "camera"))
    given = Camera.from_table(Table(dict(options, focal_px=700.0), "camera.toml", "camera"))
    points = np.array([[0.5, 0.2, 0.3], [0.0, 0.4, 0.1]])
    np.testing.assert_array_equal(default.project(points), given.project(points))
