"""The V4L2 backend: its software digitiser everywhere; a real capture card where there is one
(skipped, with the reason, on machines without /dev/video*, as the SocketCAN tests are)."""
import glob

import numpy as np
import pytest

from drivers.framegrabber_v4l2 import PictureDigitiser, V4l2FrameGrabber
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.vision.pixels import unpack

VIDEO = sorted(glob.glob("/dev/video*"))


def test_digitiser_samples_the_grid_window_and_field_lines():
    height, width = 576, 720  # a PAL capture
    rows, cols = np.mgrid[0:height, 0:width]
    picture = ((rows * 7 + cols * 3) % 256).astype(np.uint8)
    s = GrabberSettings(density=128, window=(16, 8, 64, 32), scan="odd", levels=16, word_bits=16)
    words = np.empty((s.rows, s.words_per_row), dtype="<u2")
    PictureDigitiser(s, height, width)(picture, "odd", words)
    got = unpack(words, s.bits, np.empty((s.rows, s.width), np.uint8))
    # by hand: odd-field lines of the window are grid rows 8, 10, …; grid cell centres → picture pixels
    grid_rows, grid_cols = np.arange(8, 40, 2), np.arange(16, 80)
    prow = np.floor((grid_rows + 0.5) * height / 128).astype(int)
    pcol = np.floor((grid_cols + 0.5) * width / 128).astype(int)
    expected = np.minimum(np.floor(picture[np.ix_(prow, pcol)].astype(np.float32) / 255 * 16), 15)
    np.testing.assert_array_equal(got, expected)


def test_digitiser_refuses_the_wrong_field():
    s = GrabberSettings(density=64, scan="frame", word_bits=8)
    with pytest.raises(ValueError, match="are 32 rows; these settings deliver 64"):
        PictureDigitiser(s, 100, 100)(np.zeros((100, 100), np.uint8), "odd", np.zeros((64, 64), np.uint8))


def test_options_are_validated(tmp_path):
    from rtctl.config import DeviceConfig
    from rtctl.errors import ConfigError
    from rtctl.tomltable import Table

    from drivers.framegrabber import ShmFrameGrabber

    table = Table({"backend": "v4l2", "pixel_format": "MJPG"}, tmp_path / "c.toml", "devices[0]")
    with pytest.raises(ConfigError, match="devices\\[0\\].pixel_format: one of 'GREY', 'YUYV'"):
        ShmFrameGrabber.from_config(DeviceConfig("cam", "framegrabber", (), table, "framegrabber"), None)
    table = Table({"backend": "v4l2", "device": "/dev/video7"}, tmp_path / "c.toml", "devices[0]")
    grabber = ShmFrameGrabber.from_config(DeviceConfig("cam", "framegrabber", (), table, "framegrabber"), None)
    assert isinstance(grabber, V4l2FrameGrabber) and grabber.path == "/dev/video7"


@pytest.mark.skipif(not VIDEO, reason="no /dev/video* on this machine: no V4L2 capture device to test against")
def test_real_capture_card_delivers_a_frame():
    grabber = V4l2FrameGrabber("camera", GrabberSettings(density=256, scan="frame", word_bits=8), VIDEO[0], "GREY",
                               (720, 576))
    try:
        grabber.configure()
        grabber.activate()
        import time

        t0 = time.monotonic()
        while time.monotonic() - t0 < 3.0:
            grabber.read(time.monotonic() - t0)
            frame = grabber.grab()
            if frame is not None:
                assert frame.pixels().shape == (256, 256)
                assert frame.capture_time <= time.monotonic() - t0
                return
            time.sleep(0.005)
        pytest.fail(f"no frame from {VIDEO[0]} within 3 s ({grabber.last_error})")
    finally:
        grabber.close()


class _FakeCard:
    """Stands in for linuxpy's device and capture: always a frame ready (a readable pipe for
    select), each a new sequence number and timestamp."""

    def __init__(self, height, width):
        import os
        from types import SimpleNamespace

        self._read_end, write_end = os.pipe()
        os.write(write_end, b"x")  # stays unread: select always finds the "device" readable
        self._write_end, self.height, self.width, self.seq = write_end, height, width, -1
        self.buffer = SimpleNamespace(raw_grab=self.raw_grab)

    def fileno(self):
        return self._read_end

    def raw_grab(self, into):
        from types import SimpleNamespace

        self.seq += 1
        into[:self.height * self.width] = bytes([self.seq % 256]) * (self.height * self.width)
        stamp = SimpleNamespace(secs=1000 + self.seq // 25, usecs=(self.seq % 25) * 40_000)
        return None, SimpleNamespace(sequence=self.seq, timestamp=stamp)

    def close(self):
        import os

        os.close(self._read_end)
        os.close(self._write_end)


def _take(grabber, t):
    grabber._read(t)  # what the loop's read() runs once the device is active
    return grabber.grab()


@pytest.mark.parametrize("shots", [0, 3])
def test_n_shot_hands_out_n_frames_per_trigger_and_continuous_all(shots):
    """A card streams on: N-shot hands out the next N frames after programming and after each
    trigger, and neither the frames it ignores in between nor continuous mode count as dropped."""
    height, width = 48, 64
    settings = GrabberSettings(density=64, scan="frame", word_bits=8, shots=shots)
    grabber = V4l2FrameGrabber("camera", settings, "/dev/null", "GREY", (width, height))
    card = _FakeCard(height, width)
    grabber._device = grabber._capture = card
    grabber._picture_size, grabber._stride, grabber._raw = (height, width), width, bytearray(height * width)
    try:
        grabber._write(0.0)  # programs the settings
        got = [_take(grabber, 0.01 * k) for k in range(5)]
        handed = [f.seq for f in got if f]
        assert handed == ([0, 1, 2] if shots else [0, 1, 2, 3, 4])
        grabber.trigger()
        grabber._write(0.05)
        got = [_take(grabber, 0.06 + 0.01 * k) for k in range(5)]
        assert [f.seq for f in got if f] == ([5, 6, 7] if shots else [5, 6, 7, 8, 9])
        assert grabber.dropped == 0 and grabber.frames == (6 if shots else 10)
        last = [f for f in got if f][-1]  # (the driver double-buffers: older frames' words are reused)
        assert last.pixels()[0, 0] == last.seq  # the frame's own picture (frame k: a constant grey k)
    finally:
        grabber._device = grabber._capture = None
        card.close()
