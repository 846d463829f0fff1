"""Tests for vision mutants that survived the full run's fast pass (part 12; docs/mutation/vision.md):

* ``rtctl grab``: without Pillow a PNG is an error naming the extra to install; in lock-step
  it polls at the time-out itself (1.0 s: polls at 0, 0.25 … 1.0); on the wall clock it counts
  time from its start;
* ``locate``: a box whose contrast is exactly ``min_contrast`` holds the marker (only below is
  nothing); a centre that is not finite finds nothing; a box clipped at the image's top does
  not wrap to its bottom rows; levels and ``min_contrast`` are checked (a ``min_contrast`` of 0
  let a flat box through to a centroid of no weight);
* the observer: ``search_px`` must be positive; its box is at least ±2 image columns; its
  half-size in rows is rounded up (32.5 screen px at density 512: ±33); a guess that is not
  finite measures nothing; by default it remembers 256 ticks;
* the digitiser refuses a gain that is not positive; ``pack`` names a list as no array.
"""
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from rtctl.errors import ConfigError, RtctlError
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import kinematics, load_robot
from rtctl.vision import grab
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from rtctl.vision.pixels import digitise, digitise_pack, pack, unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, READY, VISION_CONFIG, NthPoll, observer_after, predicted_at

SETTINGS = GrabberSettings(density=64, scan="frame", word_bits=8)


def test_a_png_without_pillow_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "PIL", None)  # import PIL now raises ImportError
    frame = Frame(1, 0.0, "frame", SETTINGS, np.zeros((64, 64), dtype=np.uint8), unpack)
    with pytest.raises(RtctlError, match=r"Pillow.*pip install 'rtctl\[vision\]'"):
        grab.save_png(frame, tmp_path / "frame.png")


def test_grab_in_lock_step_polls_at_the_time_out_itself():
    cfg = SimpleNamespace(file="cell.toml", sim=object(), loop=SimpleNamespace(period=0.25))
    device = NthPoll(5)
    assert grab.grab_frame(SimpleNamespace(io={"cam": device}, cfg=cfg), None, 1.0) == ("cam", "the image")
    assert device.times == [0.0, 0.25, 0.5, 0.75, 1.0]


def test_grab_on_the_wall_clock_counts_from_its_start(monkeypatch):
    clock = iter(np.arange(1000.0, 1010.0, 0.25))  # a monotonic clock far from 0
    monkeypatch.setattr(grab.time, "monotonic", lambda: next(clock))
    monkeypatch.setattr(grab.time, "sleep", lambda s: None)
    cfg = SimpleNamespace(file="cell.toml", sim=None, loop=SimpleNamespace(period=0.25))
    device = NthPoll(3)
    assert grab.grab_frame(SimpleNamespace(io={"cam": device}, cfg=cfg), None, 1.0) == ("cam", "the image")
    assert device.times == [0.0, 0.25, 0.5]


def test_a_box_whose_contrast_is_exactly_min_contrast_holds_the_marker():
    img = np.array([[255, 0]], dtype=np.uint8)  # top − mean = 127.5 = 0.5 · 255
    assert locate(img, (0.0, 0.0), (0, 1), 256, 0.5, np.zeros(4))
    assert not locate(img, (0.0, 0.0), (0, 1), 256, 0.51, np.zeros(4))


@pytest.mark.parametrize("center", [(np.nan, 4.0), (4.0, np.inf)])
def test_a_centre_that_is_not_finite_finds_nothing(center):
    img = np.zeros((8, 8), dtype=np.uint8)
    img[4, 4] = 200
    assert locate(img, center, (2, 2), 256, 0.1, np.zeros(4)) is False


def test_a_box_clipped_at_the_top_does_not_wrap_to_the_bottom():
    img = np.zeros((8, 8), dtype=np.uint8)
    img[7, 4] = 200  # the last row: outside the box of rows 0 … 2
    assert locate(img, (0.0, 4.0), (2, 2), 256, 0.1, np.zeros(4)) is False


@pytest.mark.parametrize("levels, min_contrast", [(256, 0.0), (256, -0.1), (256, 1.5), (3, 0.2), (255, 0.2)])
def test_locate_checks_levels_and_min_contrast(levels, min_contrast):
    with pytest.raises(ValueError, match="levels 2/4/16/256 and min_contrast in"):
        locate(np.zeros((8, 8), dtype=np.uint8), (4.0, 4.0), (2, 2), levels, min_contrast, np.zeros(4))


@pytest.mark.parametrize("value", ["0.0", "-8.0"])
def test_search_px_must_be_positive(tmp_path, value):
    from rtctl.config import load_config
    from rtctl.vision.observer import MarkerObserver

    path = tmp_path / "vision.toml"
    path.write_text(VISION_CONFIG.read_text().replace("search_px = 32.0", f"search_px = {value}")
                    .replace('"robots/puma560.toml"', f'"{VISION_CONFIG.parent / "robots/puma560.toml"}"'))
    c = next(c for c in load_config(path).controllers if c.type == "marker_observer")
    with pytest.raises(ConfigError) as e:
        MarkerObserver.from_config(c, load_robot(PUMA))
    assert e.value.key_path.endswith("search_px")


def _measure(observer, settings, row, col, guess_col, guess_row):
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[row, col] = 250
    guess = Camera.to_screen(np.array([guess_col, guess_row]), settings.density)
    return observer.measure(Frame(1, 0.0, "frame", settings, words, unpack), guess, np.zeros(2))


@pytest.mark.parametrize("cols_away, found", [(2, True), (3, False)])
def test_the_box_is_at_least_two_image_columns_either_way(cols_away, found):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=1.0)
    assert _measure(observer, SETTINGS, 20, 30 + cols_away, 30.0, 20.0) is found


@pytest.mark.parametrize("rows_away, found", [(33, True), (34, False)])
def test_the_boxs_half_size_in_rows_is_rounded_up(rows_away, found):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=32.5)
    settings = GrabberSettings(density=512, scan="frame", word_bits=8)
    assert _measure(observer, settings, 100 + rows_away, 200, 200.0, 100.0) is found


def test_a_guess_that_is_not_finite_measures_nothing():
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    words = np.full((64, 64), 250, dtype=np.uint8)
    out = np.zeros(2)
    assert observer.measure(Frame(1, 0.0, "frame", SETTINGS, words, unpack), np.array([np.nan, 3.0]), out) is False
    assert np.isnan(out).all()


def test_the_observer_remembers_256_ticks_by_default():
    """After 300 ticks an image older than all of them takes tick 300 − 256 = 44's positions."""
    model = load_robot(PUMA)
    q = [READY + np.radians(0.1) * k for k in range(300)]
    observer = observer_after(model, q, t0=1.0)
    tool = kinematics.fk(model, q[44])[:3, 3]
    np.testing.assert_allclose(predicted_at(observer, model, 0.5), CAMERA.project(tool), atol=1e-9)


@pytest.mark.parametrize("gain", [0.0, -0.5])
def test_the_digitiser_refuses_a_gain_that_is_not_positive(gain):
    analog = np.zeros((1, 8), dtype=np.float32)
    with pytest.raises(ValueError, match="gain > 0"):
        digitise_pack(analog, 0, gain, 256, np.zeros((1, 2), dtype="<u4"))
    with pytest.raises(ValueError, match="gain"):
        digitise(analog, 0, gain, 256, np.zeros((1, 8), dtype=np.uint8))


def test_pack_names_a_list_as_no_array():
    with pytest.raises(ValueError, match="pixels must be a 2-D uint8 array"):
        pack([[1, 2, 3, 0]], 2, 8)


def test_the_pixel_warm_up_loads_every_pixel_kernel():
    """In a fresh process, after ``pixels.warm_up()`` every compiled pixel kernel has its code:
    none is compiled later, in the loop (a skipped packing loop left two to the first image)."""
    import subprocess
    import sys

    probe = ("from rtctl.vision import pixels\npixels.warm_up()\n"
             "names = [n for n in dir(pixels) if hasattr(getattr(pixels, n), 'signatures')]\n"
             "print(sorted(n for n in names if not getattr(pixels, n).signatures))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
