"""Tests for the vision mutants that survived the suite (issue 27, part 3; docs/mutation/vision.md): the
marker search box is ``half`` pixels either side of its centre, no more, in rows and columns;
and the observer's box keeps at least ±2 image pixels either way however small ``search_px``
(docs/framegrabber.md), so a marker 2 rows off a prediction is still found; the centroid counts
only the pixels above its threshold; the digitiser's offset is a register value 0…255."""
import numpy as np
import pytest

from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import load_robot
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from rtctl.vision.pixels import digitise, unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("side", [-1, 1])
def test_locate_looks_exactly_half_pixels_either_side(axis, side):
    """A single bright pixel at ±half from the centre is found (at its own position); one pixel
    further out it is outside the (2·half + 1)-pixel box: nothing found."""
    center, half = np.array([20, 20]), (3, 4)
    out = np.zeros(4)
    for offset, inside in ((half[axis], True), (half[axis] + 1, False)):
        img = np.zeros((41, 41), dtype=np.uint8)
        spot = center.copy()
        spot[axis] += side * offset
        img[tuple(spot)] = 250
        assert locate(img, (float(center[0]), float(center[1])), half, 256, 0.2, out) is inside, (offset, spot)
        if inside:
            np.testing.assert_allclose(out[:2], spot)


@pytest.mark.parametrize(("d_row", "d_col"), [(2, 0), (-2, 0), (0, 2), (0, -2)])
def test_the_observer_box_keeps_two_image_pixels_either_way(d_row, d_col):
    from rtctl.vision.observer import MarkerObserver

    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=1.0)  # an eighth of an image pixel
    guess_grid = np.array([30.0, 30.0])  # (x = column, y = row) in image pixels: window at the origin
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[30 + d_row, 30 + d_col] = 250
    out = np.zeros(2)
    frame = Frame(1, 0.0, "frame", settings, words, unpack)
    assert observer.measure(frame, Camera.to_screen(guess_grid, settings.density), out)
    np.testing.assert_allclose(Camera.to_grid(out, settings.density), guess_grid + [d_col, d_row], atol=1e-9)


def test_the_centroid_counts_only_pixels_above_the_threshold():
    """One row of three: 240, 192, 0 — mean 144, threshold ½(240 + 144) = 192 exactly. Only the
    240 is above it: weight 48, one pixel, at its own place (by the definition, by hand)."""
    img = np.array([[240, 192, 0]], dtype=np.uint8)
    out = np.zeros(4)
    assert locate(img, (0.0, 1.0), (0, 1), 256, 0.1, out)
    np.testing.assert_array_equal(out, [0.0, 0.0, 48.0, 1.0])


@pytest.mark.parametrize("offset", [-1, 256])
def test_digitise_refuses_an_offset_outside_the_register(offset):
    """The offset is a register value, 0…255 (docs/framegrabber.md)."""
    analog, out = np.zeros(4), np.zeros(4, dtype=np.uint8)
    with pytest.raises(ValueError, match="offset 0..255"):
        digitise(analog, offset, 1.0, 256, out)
    digitise(analog, 0 if offset < 0 else 255, 1.0, 256, out)  # (the ends themselves are taken)
