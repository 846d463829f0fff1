"""Tests for vision mutants that survived the full run's fast pass (part 6; docs/mutation/vision.md):

* a host attaches to a buffer of any documented slot count, 4 … 16, the bounds included;
* a camera's ``principal`` is two numbers, (u0, v0), where the line of sight meets the screen;
* the digitiser takes a black offset of 255 (the top of its documented 0…255);
* the observer's allocation-free ``project_point`` is the pinhole projection, as ``project`` is:
  both against the projection written from the camera's axes (z toward the target, x = z × up
  to the image's right, y = z × x down the image);
* ``rtctl grab`` warms a framegrabber's compiled code up before it activates the device and
  starts the wait for a first image (a compile then does not count against ``--timeout``), and
  takes a device that has nothing to warm up.
"""
from types import SimpleNamespace

import numpy as np
import pytest

from drivers.protocols.framegrabber import MAX_SLOTS, MIN_SLOTS, GrabberMemory, buffer_bytes
from rtctl.hal.framegrabber import FrameGrabber, GrabberSettings
from rtctl.tomltable import Table
from rtctl.vision.camera import Camera
from rtctl.vision.grab import grab_frame
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
