"""Tests for vision mutants that survived the full run's fast pass (part 6; docs/mutation/vision.md):

* a host attaches to a buffer of any documented slot count, 4 … 16, the bounds included;
* a camera's ``principal`` is two numbers, (u0, v0), where the line of sight meets the screen;
* the digitiser takes a black offset of 255 (the top of its documented 0…255);
* the observer's allocation-free ``project_point`` is the pinhole projection, as ``project`` is:
  both against the projection written from the camera's axes (z toward the target, x = z × up
  to the image's right, y = z × x down the image);
* ``rtctl grab`` warms a framegrabber's compiled code up before it activates the device and
  starts the wait for a first image (a compile then does not count against ``--timeout``), and
  takes a device that has nothing to warm up; without the device asked for, it names the ones
  there are;
* the wire's numbers are those its docstring gives, read as raw words: the clock word (0 or 1)
  and a slot's sequence word while the device writes it (−1);
* a slot stride that puts the slots past the buffer's end is refused;
* ``digitise`` refuses video that is not a C-contiguous float32/float64 array;
* a black box holds no marker, whatever the grey scale.
"""
from types import SimpleNamespace

import numpy as np
import pytest

from drivers.protocols.framegrabber import MAX_SLOTS, MIN_SLOTS, DevicePort, GrabberMemory, buffer_bytes
from rtctl.errors import ProtocolError, RtctlError
from rtctl.hal.framegrabber import FrameGrabber, GrabberSettings
from rtctl.tomltable import Table
from rtctl.vision.camera import Camera
from rtctl.vision.grab import grab_frame
from rtctl.vision.marker import locate
from rtctl.vision.pixels import digitise, digitise_pack


@pytest.mark.parametrize("n_slots", [MIN_SLOTS, MAX_SLOTS])
def test_a_host_attaches_to_the_smallest_and_the_largest_buffer(n_slots):
    buffer = np.zeros(buffer_bytes(n_slots), dtype=np.uint8)
    GrabberMemory(buffer, create=True, n_slots=n_slots)  # the device's side
    assert GrabberMemory(buffer).n_slots == n_slots  # the host's side checks the layout


def test_a_cameras_principal_point_is_where_the_line_of_sight_meets_the_screen():
    target = [0.35, 0.05, 0.0]
    options = {"position": [1.7, -1.2, 0.9], "look_at": target, "focal_px": 760.0, "principal": [320.0, 240.0]}
    camera = Camera.from_table(Table(options, "camera.toml", "camera"))
    assert camera.project(np.array(target)) == pytest.approx([320.0, 240.0], abs=1e-9)


def test_a_black_offset_of_255_is_taken_and_leaves_every_pixel_black():
    analog = np.linspace(0.0, 1.0, 16, dtype=np.float32).reshape(2, 8)
    grey = np.full(analog.shape, 7, dtype=np.uint8)
    assert digitise(analog, 255, 1.0, 16, grey).tolist() == [[0] * 8] * 2
    words = np.full((2, 1), 0xFFFFFFFF, dtype="<u4")
    assert digitise_pack(analog, 255, 1.0, 16, words).tolist() == [[0], [0]]


def _pinhole(position, target, up, focal, principal, p):
    """(u, v) of base-frame point ``p``, from the camera's axes, or None behind the camera."""
    z = (target - position) / np.linalg.norm(target - position)
    x = np.cross(z, up) / np.linalg.norm(np.cross(z, up))
    y = np.cross(z, x)
    d = p - position
    if d @ z <= 0:
        return None
    return principal + focal * np.array([d @ x, d @ y]) / (d @ z)


def test_project_point_is_the_pinhole_projection():
    rng = np.random.default_rng(7)
    out = np.empty(2)
    for _ in range(200):
        position, target = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3)
        up = rng.normal(size=3)
        if np.linalg.norm(np.cross(target - position, up)) < 0.1 * np.linalg.norm(target - position):
            continue  # (up nearly along the line of sight)
        focal, principal = rng.uniform(300, 900), rng.uniform(100, 400, 2)
        camera = Camera.looking_at(position, target, focal, principal, up)
        p = rng.uniform(-3, 3, 3)
        expected = _pinhole(position, target, up, focal, principal, p)
        if expected is None:
            assert camera.project_point(p, out) is False and np.isnan(out).all()
            assert np.isnan(camera.project(p)).all()
        else:
            assert camera.project_point(p, out) is True
            assert out == pytest.approx(expected, rel=1e-9, abs=1e-6)
            assert camera.project(p) == pytest.approx(expected, rel=1e-9, abs=1e-6)


class _Grabber(FrameGrabber):
    """A device whose first image arrives at the second poll; it records its lifecycle."""

    def __init__(self, events):
        super().__init__("cam", GrabberSettings(density=64, scan="frame", word_bits=8))
        self.events, self.polls = events, 0

    def _on_activate(self):
        self.events.append("activate")
        super()._on_activate()

    def _send(self, settings, t):
        pass

    def _poll(self, t):
        self.polls += 1
        self._latest = SimpleNamespace(copy=lambda: "the image")
        return self.polls == 2


class _WarmGrabber(_Grabber):
    def warm_up(self):
        self.events.append("warm_up")


@pytest.mark.parametrize(("grabber", "events"), [(_WarmGrabber, ["warm_up", "activate"]), (_Grabber, ["activate"])])
def test_grab_warms_the_device_up_before_it_activates_it(grabber, events):
    seen = []
    cfg = SimpleNamespace(file="cell.toml", sim=object(), loop=SimpleNamespace(period=0.001))
    runtime = SimpleNamespace(io={"cam": grabber(seen)}, cfg=cfg)
    assert grab_frame(runtime, None, 1.0) == ("cam", "the image")
    assert seen == events


@pytest.mark.parametrize(("devices", "device", "message"), [
    ({"cam": _Grabber}, "left", "cell.toml: no framegrabber device named 'left'; framegrabber devices: cam"),
    ({}, None, "cell.toml: framegrabber devices: none"),
])
def test_grab_without_the_device_names_the_framegrabbers_there_are(devices, device, message):
    cfg = SimpleNamespace(file="cell.toml", sim=object(), loop=SimpleNamespace(period=0.001))
    runtime = SimpleNamespace(io={name: kind([]) for name, kind in devices.items()}, cfg=cfg)
    with pytest.raises(RtctlError) as caught:
        grab_frame(runtime, device, 1.0)
    assert str(caught.value) == message


def _word(buffer, byte):
    return int(buffer[byte:byte + 8].view("<i8")[0])


@pytest.mark.parametrize(("clock", "word"), [("CLOCK_MONOTONIC", 0), ("CLOCK_LOOP", 1)])
def test_the_clock_word_is_the_documented_number(clock, word):
    from drivers.protocols import framegrabber

    buffer = np.zeros(buffer_bytes(), dtype=np.uint8)
    GrabberMemory(buffer, create=True, clock=getattr(framegrabber, clock))
    assert _word(buffer, 8 + 8 * 4) == word  # LAYOUT: version, n_slots, slot_stride, data_bytes, clock


def test_a_slot_being_written_reads_minus_one_and_zero_once_given_back():
    buffer = np.zeros(buffer_bytes(), dtype=np.uint8)
    device = DevicePort(GrabberMemory(buffer, create=True))
    slot = device.reserve()
    assert _word(buffer, 384 + 8 * (2 + slot)) == -1  # WRITER: published, written, slot_seq[...]
    device.abandon(slot)
    assert _word(buffer, 384 + 8 * (2 + slot)) == 0


def test_a_slot_stride_that_puts_the_slots_past_the_buffer_is_refused():
    buffer = np.zeros(buffer_bytes(), dtype=np.uint8)
    memory = GrabberMemory(buffer, create=True)
    stride = int(memory.layout[2]) + 8  # a multiple of 8, long enough: the last slot ends past the buffer
    memory.layout[2] = stride
    with pytest.raises(ProtocolError, match=f"slot stride {stride} .* {MIN_SLOTS} slots within {buffer.size} bytes"):
        GrabberMemory(buffer)


@pytest.mark.parametrize("analog", [np.zeros((2, 8), dtype=np.int16), np.zeros((8, 2), dtype=np.float32).T],
                         ids=["int16", "transposed"])
def test_digitise_refuses_video_that_is_not_contiguous_float(analog):
    with pytest.raises(ValueError, match="analog must be a C-contiguous float32/float64 array"):
        digitise(analog, 0, 1.0, 16, np.zeros(analog.shape, dtype=np.uint8))


@pytest.mark.parametrize("levels", [2, 4, 16, 256])
def test_a_black_box_holds_no_marker(levels):
    out = np.zeros(4)
    assert locate(np.zeros((9, 9), dtype=np.uint8), (4, 4), (2, 2), levels, 0.2, out) is False
