"""Tests for vision mutants that survived the full run's fast pass (part 9; docs/mutation/vision.md):

* a camera whose up direction lies along its line of sight is refused (it has no image x axis);
* a point in the camera's own plane (z = 0) is behind it: NaN, as for ``project_point``;
* ``rtctl grab``'s PNG spans black to white whatever the grey levels: level k of L is
  k · 255 / (L − 1), exact for the 2, 4, 16 and 256 levels;
* in lock-step ``rtctl grab`` advances simulated time and never sleeps on the wall clock;
* in an even field the observer's box is centred on the guess's own image row: a marker at the
  box's top edge is found (grid row 2 · image row + 1);
* video brighter than full scale saturates at the top level: every packed code L − 1.
"""
from types import SimpleNamespace

import numpy as np
import pytest

from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import load_robot
from rtctl.vision import grab
from rtctl.vision.camera import Camera
from rtctl.vision.pixels import digitise_pack, unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, NthPoll


@pytest.mark.parametrize("up", [(0.0, 0.0, 1.0), (0.0, 0.0, -3.0), (1e-12, 0.0, 1.0)])
def test_a_camera_whose_up_is_along_its_line_of_sight_is_refused(up):
    with pytest.raises(ValueError, match="along the line of sight"):
        Camera.looking_at((0.0, 0.0, 2.0), (0.0, 0.0, 0.0), up=up)


def test_a_point_in_the_cameras_plane_is_behind_it():
    camera = Camera.looking_at((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))  # z = base x, exactly
    in_plane = np.array([0.0, 1.0, 0.0])
    assert np.isnan(camera.project(in_plane)).all()
    assert camera.project_point(in_plane, np.zeros(2)) is False
    assert np.isfinite(camera.project(np.array([1e-6, 1.0, 0.0]))).all()  # just in front


@pytest.mark.parametrize("levels, word_bits", [(2, 8), (4, 8), (16, 16), (256, 8)])
def test_a_grabbed_png_spans_black_to_white(tmp_path, levels, word_bits):
    from PIL import Image

    settings = GrabberSettings(density=64, scan="frame", levels=levels, word_bits=word_bits)
    analog = np.tile(np.linspace(0.0, 1.0, settings.width, dtype=np.float32), (settings.rows, 1))
    words = np.zeros((settings.rows, settings.words_per_row), dtype=f"<u{word_bits // 8}")
    digitise_pack(analog, 0, 1.0, levels, words)  # every level from 0 to levels - 1 along a row
    grab.save_png(Frame(1, 0.0, "frame", settings, words, unpack), tmp_path / "frame.png")
    png = np.asarray(Image.open(tmp_path / "frame.png"))
    codes = Frame(1, 0.0, "frame", settings, words, unpack).pixels()
    assert png.min() == 0 and png.max() == 255
    np.testing.assert_array_equal(png, codes * (255 // (levels - 1)))  # 255 = 1·255 = 3·85 = 15·17


def test_grab_in_lock_step_steps_simulated_time_and_never_sleeps(monkeypatch):
    def no_sleep(seconds):
        raise AssertionError(f"slept {seconds} s in lock-step")

    monkeypatch.setattr(grab.time, "sleep", no_sleep)
    cfg = SimpleNamespace(file="cell.toml", sim=object(), loop=SimpleNamespace(period=0.002))
    device = NthPoll(5)
    assert grab.grab_frame(SimpleNamespace(io={"cam": device}, cfg=cfg), None, 1.0) == ("cam", "the image")
    assert device.times == pytest.approx([0.0, 0.002, 0.004, 0.006, 0.008], abs=1e-12)


def test_an_even_fields_box_is_centred_on_the_guess_row():
    """search_px 16 at density 64: a box of ±2 image rows. The guess is grid row 21, image row
    10 of the even field; the marker is at image row 8 (grid row 17), the box's top edge."""
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=16.0)
    settings = GrabberSettings(density=64, scan="even", word_bits=8)
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[8, 30] = 250
    guess = Camera.to_screen(np.array([30.0, 21.0]), settings.density)
    out = np.zeros(2)
    assert observer.measure(Frame(1, 0.0, "even", settings, words, unpack), guess, out)
    np.testing.assert_allclose(Camera.to_grid(out, settings.density), [30.0, 17.0], atol=1e-9)


@pytest.mark.parametrize("levels, word_bits", [(2, 8), (4, 8), (16, 16), (256, 8), (4, 32)])
def test_video_over_full_scale_saturates_at_the_top_level(levels, word_bits):
    settings = GrabberSettings(density=64, scan="frame", levels=levels, word_bits=word_bits)
    analog = np.full((settings.rows, settings.width), 1.7, dtype=np.float32)
    words = np.zeros((settings.rows, settings.words_per_row), dtype=f"<u{word_bits // 8}")
    digitise_pack(analog, 0, 1.0, levels, words)
    assert (words == np.iinfo(words.dtype).max).all()  # every code levels - 1: every bit set
