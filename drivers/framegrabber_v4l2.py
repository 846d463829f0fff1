"""The framegrabber driver's V4L2 backend: a real capture card through Video4Linux2 (linuxpy).

A capture card digitises the TV signal itself, at its own resolution, in 8-bit grey (or
YUYV, of which the luma is kept). This backend then does in software what the paper's
interface does in hardware, so the loop sees the same frames from either:
:class:`PictureDigitiser` samples the picture on the settings' 2^k grid (nearest sample),
keeps the window and the field's lines, applies offset, gain and levels and packs the words.
A "field" is the field's lines of a captured frame (and "fields" alternates them), at the
card's frame rate. Capture times are the card's buffer timestamps (CLOCK_MONOTONIC), put on
the loop's clock (:class:`rtctl.hal.framegrabber.LoopClock`); the sequence number is the card's.
N-shot (``shots`` = N): a card streams on, so the backend hands out the next N frames after each
programming (or ``trigger()``) and discards the rest unseen — they are not counted as dropped.

Options (``backend = "v4l2"``): ``device`` (default ``/dev/video0``), ``pixel_format``
("GREY" or "YUYV"), ``capture_size`` ([width, height], default [720, 576], PAL), and
``[devices.settings]``. Needs the optional extra ``vision`` (linuxpy).
"""
from __future__ import annotations

import select
import time

import numpy as np

from rtctl.errors import HardwareError
from rtctl.hal.framegrabber import Frame, FrameGrabber, GrabberSettings, LoopClock
from rtctl.vision.pixels import WORD_DTYPES, digitise, pack, unpack

PIXEL_FORMATS = ("GREY", "YUYV")


class PictureDigitiser:
    """An 8-bit grey picture (height, width) → the packed words the settings describe."""

    def __init__(self, settings: GrabberSettings, height: int, width: int):
        s = self.settings = settings
        x, y, w, h = s.window
        grid_rows = np.arange(y, y + h)
        self.rows = {"frame": grid_rows, "odd": grid_rows[(grid_rows % 2) == 0], "even": grid_rows[grid_rows % 2 == 1]}
        # grid cell centre → nearest picture sample
        self.rows = {k: np.minimum(((r + 0.5) * height / s.density_v).astype(np.intp), height - 1)
                     for k, r in self.rows.items()}
        self.cols = np.minimum(((np.arange(x, x + w) + 0.5) * width / s.density_h).astype(np.intp), width - 1)
        self._sampled = np.empty((s.rows, s.width), dtype=np.uint8)
        self._analog = np.empty((s.rows, s.width), dtype=np.float32)
        self._levels = np.empty((s.rows, s.width), dtype=np.uint8)
        self._rows_buf = np.empty((s.rows, width), dtype=np.uint8)

    def __call__(self, picture: np.ndarray, field: str, out: np.ndarray) -> np.ndarray:
        """Digitise the lines of ``field`` ("frame", "odd", "even") of ``picture`` into ``out``."""
        s = self.settings
        rows = self.rows[field]
        if rows.size != s.rows:
            raise ValueError(f"the {field} lines of the window are {rows.size} rows; these settings deliver {s.rows}")
        np.take(picture, rows, axis=0, out=self._rows_buf[:rows.size])
        np.take(self._rows_buf[:rows.size], self.cols, axis=1, out=self._sampled)
        np.multiply(self._sampled, np.float32(1 / 255), out=self._analog)
        digitise(self._analog, s.offset, s.gain_factor, s.levels, self._levels)
        return pack(self._levels, s.bits, s.word_bits, out)


class V4l2FrameGrabber(FrameGrabber):
    def __init__(self, name: str, settings: GrabberSettings, path: str, pixel_format: str, size: tuple[int, int]):
        super().__init__(name, settings)
        self.path, self.pixel_format, self.size = path, pixel_format, size
        self._device = self._capture = None
        self._last_seq: int | None = None  # the card's sequence number of the last frame
        self._parity = 0
        self._shots_left = -1  # N-shot: frames still to hand out (-1: continuous)
        self._clock = LoopClock()

    @classmethod
    def from_config(cls, device, context) -> "V4l2FrameGrabber":
        from drivers.framegrabber import settings_table

        o = device.options
        size = o.vector("capture_size", 2, np.array([720.0, 576.0]))
        if not all(v >= 1 and v == int(v) for v in size):
            raise o.error("capture_size", f"[width, height] in pixels, got {size.tolist()}")
        grabber = cls(device.name, GrabberSettings.from_table(settings_table(o)), o.str("device", "/dev/video0"),
                      o.str("pixel_format", "GREY", choices=PIXEL_FORMATS), (int(size[0]), int(size[1])))
        o.raw("scene", None)  # the simulator's: what the camera sees, and its card's rate
        o.raw("transfer_mb_s", None)
        o.done()
        return grabber

    def _on_configure(self) -> None:
        try:
            from linuxpy.video.device import BufferType, Device, VideoCapture
        except ImportError:
            raise HardwareError(f"{self.name}: the V4L2 backend needs linuxpy, in the optional extra "
                                f"`vision`: pip install 'rtctl[vision]'") from None
        try:
            self._device = Device(self.path, blocking=False)
            self._device.open()
            self._device.set_format(BufferType.VIDEO_CAPTURE, *self.size, self.pixel_format)
            fmt = self._device.get_format(BufferType.VIDEO_CAPTURE)
            self._capture = VideoCapture(self._device, size=4)
            self._capture.arm()
        except Exception as e:
            self._on_close()
            raise HardwareError(f"{self.name}: {self.path}: {type(e).__name__}: {e}") from None
        self._picture_size = (fmt.height, fmt.width)
        self._stride = fmt.bytes_per_line or fmt.width * (2 if self.pixel_format == "YUYV" else 1)
        self._raw = bytearray(max(fmt.size, fmt.height * self._stride))

    def _on_activate(self) -> None:
        self._capture.open()  # stream on
        super()._on_activate()

    def _send(self, settings: GrabberSettings, t: float) -> None:
        self._digitiser = PictureDigitiser(settings, *self._picture_size)
        self._words = [np.empty((settings.rows, settings.words_per_row), dtype=WORD_DTYPES[settings.word_bits])
                       for _ in range(2)]  # the frame handed out, and the next one
        self._shots_left = settings.shots if settings.shots else -1

    def _poll(self, t: float) -> bool:
        if self._capture is None or self._capture.buffer is None or not hasattr(self, "_digitiser"):
            return False
        if not select.select((self._device,), (), (), 0)[0]:
            return False
        data, buff = self._capture.buffer.raw_grab(into=self._raw)
        seq = int(buff.sequence)
        if self._shots_left == 0:  # the burst is complete: idle until triggered (the card streams on)
            self._last_seq = seq
            return False
        height, width = self._picture_size
        lines = np.frombuffer(self._raw, dtype=np.uint8)[:height * self._stride].reshape(height, self._stride)
        picture = lines[:, 0:2 * width:2] if self.pixel_format == "YUYV" else lines[:, :width]
        s = self._digitiser.settings
        field = {"fields": ("odd", "even")[self._parity], "frame": "frame"}.get(s.scan, s.scan)
        self._parity ^= 1
        if self._last_seq is not None:
            self.dropped += max(0, seq - self._last_seq - 1)  # frames the card completed that we missed
        self._last_seq = seq
        self.frames += 1
        if self._shots_left > 0:
            self._shots_left -= 1
        words = self._words[self.frames % 2]
        self._digitiser(np.ascontiguousarray(picture), field, words)
        capture_ns = buff.timestamp.secs * 1_000_000_000 + buff.timestamp.usecs * 1000
        self._latest = Frame(seq, self._clock.to_loop(t, time.monotonic_ns(), capture_ns), field, s, words, unpack)
        return True

    def _on_close(self) -> None:
        try:
            if self._capture is not None:
                self._capture.close()
        finally:
            if self._device is not None:
                self._device.close()
            self._capture = self._device = None
