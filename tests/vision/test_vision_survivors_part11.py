"""Tests for vision mutants that survived the full run's fast pass (part 11; docs/mutation/vision.md):

* a buffer as long as the header, with the magic, is refused for not holding its slots, not as
  "bad magic";
* ``rtctl grab``'s time-out names simulated time in lock-step and wall time otherwise;
* ``locate`` refuses an ``out`` that is not float64;
* ``min_contrast`` is a fraction of levels − 1, not of levels: a peak 3.16 levels above its
  box's mean passes 0.2 of 16 levels (3.0), which 0.2 · 16 (3.2) would not;
* ``min_contrast = 1`` is taken (the documented "at most 1");
* the observer's box in a field is ±ceil(search_px · density / 512 / 2) image rows: search_px
  40 at density 64 gives ±3 (a floor division gave ±2), and by default it reaches 32 screen
  pixels up and down as well as across;
* an image older than the history takes the oldest row in it, before and after the ring wraps;
* ``pack`` drops a level's higher bits instead of spilling them into its neighbours.
"""
from types import SimpleNamespace

import numpy as np
import pytest

from drivers.protocols.framegrabber import HEADER_BYTES, GrabberMemory, buffer_bytes
from rtctl.errors import HardwareError, ProtocolError
from rtctl.hal.framegrabber import Frame, FrameGrabber, GrabberSettings
from rtctl.model import kinematics, load_robot
from rtctl.vision import grab
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from rtctl.vision.pixels import pack, unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, READY, observer_after, observer_config, predicted_at


def test_a_buffer_of_only_the_header_is_refused_for_its_slots_not_its_magic():
    made = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True)
    short = np.frombuffer(made.buffer, dtype=np.uint8)[:HEADER_BYTES].copy()
    with pytest.raises(ProtocolError, match=f"slot stride .* 4 slots within {HEADER_BYTES} bytes"):
        GrabberMemory(short)


class _Blind(FrameGrabber):
    def __init__(self):
        super().__init__("cam", GrabberSettings(density=64, scan="frame", word_bits=8))

    def _send(self, settings, t):
        pass

    def _poll(self, t):
        return False


@pytest.mark.parametrize("sim, clock", [(object(), "simulated"), (None, "wall")])
def test_grabs_time_out_names_its_clock(monkeypatch, sim, clock):
    monkeypatch.setattr(grab.time, "sleep", lambda s: None)
    ticks = iter(np.arange(0.0, 10.0, 0.004))
    monkeypatch.setattr(grab.time, "monotonic", lambda: next(ticks))
    cfg = SimpleNamespace(file="cell.toml", sim=sim, loop=SimpleNamespace(period=0.004))
    with pytest.raises(HardwareError, match=f"cam: no image within 0.01 s of {clock} time"):
        grab.grab_frame(SimpleNamespace(io={"cam": _Blind()}, cfg=cfg), None, 0.01)


def test_locate_refuses_an_out_that_is_not_float64():
    img = np.zeros((8, 8), dtype=np.uint8)
    with pytest.raises(ValueError, match="float64 array of 4"):
        locate(img, (4.0, 4.0), (2, 2), 256, 0.1, np.zeros(4, dtype=np.float32))


def test_min_contrast_is_a_fraction_of_levels_minus_one_not_of_levels():
    img = np.zeros((5, 5), dtype=np.uint8)
    img.flat[:17] = 1
    img[4, 4] = 4  # mean (4 + 17) / 25: the peak stands 79/25 = 3.16 levels above it
    assert locate(img, (2.0, 2.0), (2, 2), 16, 0.2, np.zeros(4))  # 3.16 ≥ 0.2 · 15


def test_a_min_contrast_of_one_is_taken(tmp_path):
    from rtctl.vision.observer import MarkerObserver

    _, c = observer_config(tmp_path, "min_contrast = 1.0")
    assert MarkerObserver.from_config(c, load_robot(PUMA)).min_contrast == 1.0


def _marker_at(settings, row, col):
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[row, col] = 250
    return Frame(1, 0.0, settings.scan if settings.scan != "fields" else "odd", settings, words, unpack)


@pytest.mark.parametrize("rows_away, found", [(3, True), (4, False)])
def test_a_fields_box_is_the_search_divided_by_two_rounded_up(rows_away, found):
    """search_px 40 at density 64: 40 · 64 / 512 = 5 grid rows, 2.5 field rows: ±3."""
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=40.0)
    settings = GrabberSettings(density=64, scan="odd", word_bits=8)
    guess = Camera.to_screen(np.array([30.0, 2 * 10.0]), settings.density)  # odd field: image row 10
    out = np.zeros(2)
    assert observer.measure(_marker_at(settings, 10 + rows_away, 30), guess, out) is found


@pytest.mark.parametrize("offset, found", [(32, True), (33, False)])
def test_the_default_search_box_reaches_32_screen_pixels_down(offset, found):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    settings = GrabberSettings(density=512, scan="frame", word_bits=8)
    guess = Camera.to_screen(np.array([100.0, 200.0]), settings.density)
    assert observer.measure(_marker_at(settings, 200 + offset, 100), guess, np.zeros(2)) is found


@pytest.mark.parametrize("ticks", [3, 6])
def test_an_image_older_than_the_history_takes_its_oldest_row(ticks):
    """A history of 4 ticks: after 3 the oldest row is the first tick's; after 6 (the ring has
    wrapped) it is the third's."""
    model = load_robot(PUMA)
    q = [READY + np.radians(5.0) * k for k in range(ticks)]
    observer = observer_after(model, q, t0=1.0, history=4)
    tool = kinematics.fk(model, q[max(0, ticks - 4)])[:3, 3]
    np.testing.assert_allclose(predicted_at(observer, model, 0.5), CAMERA.project(tool), atol=1e-9)


def test_pack_drops_a_levels_higher_bits():
    pixels = np.array([[0, 5, 0, 0]], dtype=np.uint8)  # 5 = 0b101 in a 2-bit level: 0b01 kept
    assert pack(pixels, 2, 8).tolist() == [[0b00_01_00_00]]
