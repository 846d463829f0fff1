"""Tests for vision mutants that survived the full run's fast pass (part 8; docs/mutation/vision.md):

* a frame's registers with a scan code outside the four scans are no settings (a negative code
  is not the last scan counted from the end);
* the marker's centroid weights every pixel above the threshold by how far above it is, a
  pixel 0.68 of a level above included (the module docstring), against the centroid computed
  here by hand;
* a camera's focal length defaults to 700 screen pixels (docs/framegrabber.md);
* the marker observer's warm-up leaves no trace in its telemetry: before the first image the
  measured, predicted and error pixels and the capture time are NaN, the frame number 0;
* it finds a marker in a window whose corner is not the grid's (image column + window x);
* bound to anything but one framegrabber it names what it was given, or "none";
* after a reset, an image takes the joint positions interpolated at its capture time between
  the two ticks around it, or the newest after it (its predicted pixel: the tool there, by
  forward kinematics).
"""
import re

import numpy as np
import pytest

from drivers.protocols.framegrabber import decode, encode
from rtctl.errors import SettingsError
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.hal.joints import JointState
from rtctl.model import kinematics, load_robot
from rtctl.tomltable import Table
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from rtctl.vision.pixels import unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, READY, NoImages, observer_after, predicted_at

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


def test_the_observers_warm_up_leaves_its_telemetry_empty():
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    observer.grabber = NoImages()
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


def test_the_observer_finds_a_marker_in_a_window_off_the_grids_corner():
    """A 32 × 16 window at grid (16, 8): image pixel (row 5, column 10) is grid (26, 13)."""
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    settings = GrabberSettings(density=64, window=(16, 8, 32, 16), scan="frame", word_bits=8)
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[5, 10] = 250
    guess = Camera.to_screen(np.array([26.0, 13.0]), settings.density)
    out = np.zeros(2)
    assert observer.measure(Frame(1, 0.0, "frame", settings, words, unpack), guess, out)
    np.testing.assert_allclose(Camera.to_grid(out, settings.density), [26.0, 13.0], atol=1e-9)


@pytest.mark.parametrize("devices", [{}, {"camera": NoImages()}])
def test_an_observer_without_its_framegrabber_names_what_it_was_given(devices):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    expected = "got none" if not devices else "got camera (NoImages)"
    with pytest.raises(ValueError, match=rf"exactly one framegrabber device; {re.escape(expected)}"):
        observer.bind(devices)


@pytest.mark.parametrize("capture, between, w", [(0.00025, 0, 0.25), (0.0015, 1, 0.5), (0.003, 2, 0.0)])
def test_an_image_takes_the_positions_interpolated_at_its_capture_time(capture, between, w):
    """Ticks at 0, 1 and 2 ms after a reset: an image captured a quarter of the way into the
    first interval, halfway into the second, or after the newest tick (which it takes)."""
    model = load_robot(PUMA)
    q = [READY + np.radians(10.0) * k for k in range(4)]
    observer = observer_after(model, q[:3])
    q_at = q[between] + w * (q[between + 1] - q[between])
    tool = kinematics.fk(model, q_at)[:3, 3]
    np.testing.assert_allclose(predicted_at(observer, model, capture), CAMERA.project(tool), atol=1e-9)
