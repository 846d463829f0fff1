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
