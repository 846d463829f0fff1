"""FrameGrabber: the universal computer vision interface as a HAL device (docs/framegrabber.md).

The paper's interface digitises a composite TV signal on a programmable grid and delivers
packed pixels through on-board memory shared with the host. Its settings are
:class:`GrabberSettings`; every combination the device cannot do is refused with a
:class:`~rtctl.errors.SettingsError` naming the key (in a configuration: exit 2 with the
file and key path). A :class:`Frame` carries its sequence number, its capture time on the
loop's clock and the settings it was taken with.

The loop calls ``read`` in its READ phase: it picks up the newest complete frame without
waiting (a frame the device completed while nobody looked is *dropped* and counted).
:meth:`FrameGrabber.grab` then hands that frame out once, or None. ``write`` (WRITE phase)
sends settings changed with :meth:`FrameGrabber.apply`; activating the device programs it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rtctl.errors import SettingsError
from rtctl.hal.lifecycle import Hardware, Status

DENSITIES = (64, 128, 256, 512)  # 2^k samples along each axis, k = 6..9: 4 × 4 = the paper's 16 modes
SCANS = ("odd", "even", "fields", "frame")  # odd or even fields (25 Hz), every field (50 Hz), interlaced frames (25 Hz)
LEVELS = {2: 1, 4: 2, 16: 4, 256: 8}  # grey levels → bits per pixel
WORD_BITS = (8, 16, 32)  # the parallel output's word
MEMORY_BYTES = 256 * 1024  # on-board RAM: what one N-shot burst must fit
FIELD_PERIOD_S = 0.020  # PAL: a field every 20 ms, a frame (two fields) every 40 ms
FIELD_NS = round(FIELD_PERIOD_S * 1e9)
UNITY_GAIN = 128  # gain register value of a ×1 amplifier (factor 2^((gain − 128)/64))


@dataclass(frozen=True)
class GrabberSettings:
    """What the host programs into the interface. Coordinates are on the sampling grid over
    the full screen; ``window`` = (x, y, width, height).

    ``density`` is the grid: one 2^k for a square grid, or ``(horizontal, vertical)`` — samples
    along a line, lines over the frame — each 2^k with k = 6..9 chosen independently, the
    paper's 16 modes (§2). A pair with equal halves is stored as the one number, so each mode
    has one form. A single field holds every other line: ``(256, 512)`` gives the paper's
    256 × 256 field, ``512`` its 256 × 512 field."""

    density: int | tuple[int, int] = 512
    window: tuple[int, int, int, int] | None = None  # None: the full grid
    scan: str = "fields"
    offset: int = 0  # black level subtracted, in 1/255 of full scale (256 steps)
    gain: int = UNITY_GAIN  # amplifier factor 2^((gain − 128)/64), ×1/4 … ×4 (256 steps)
    levels: int = 256
    word_bits: int = 32
    shots: int = 0  # 0: continuous; N: N frames, then idle until triggered again

    def __post_init__(self):
        d = tuple(self.density) if isinstance(self.density, list) else self.density
        _check_density(d)
        object.__setattr__(self, "density", d[0] if isinstance(d, tuple) and d[0] == d[1] else d)
        if self.window is None:
            object.__setattr__(self, "window", (0, 0, self.density_h, self.density_v))
        self.validate()

    # -- derived ------------------------------------------------------------------------
    @property
    def density_h(self) -> int:
        """Samples along a line: the grid's columns."""
        return self.density if isinstance(self.density, (int, np.integer)) else self.density[0]

    @property
    def density_v(self) -> int:
        """Lines over the full frame (both fields): the grid's rows."""
        return self.density if isinstance(self.density, (int, np.integer)) else self.density[1]

    @property
    def bits(self) -> int:
        return LEVELS[self.levels]

    @property
    def rows(self) -> int:
        """Rows of the delivered image (a field holds every other line of the window)."""
        return self.window[3] if self.scan == "frame" else self.window[3] // 2

    @property
    def width(self) -> int:
        return self.window[2]

    @property
    def words_per_row(self) -> int:
        return self.width * self.bits // self.word_bits

    @property
    def frame_bytes(self) -> int:
        return self.rows * self.words_per_row * self.word_bits // 8

    @property
    def period_s(self) -> float:
        """Time between images: every field 20 ms; odd or even fields, or frames, 40 ms."""
        return FIELD_PERIOD_S if self.scan == "fields" else 2 * FIELD_PERIOD_S

    @property
    def gain_factor(self) -> float:
        return 2.0 ** ((self.gain - UNITY_GAIN) / 64.0)

    # -- validation ------------------------------------------------------------------------
    def validate(self) -> None:
        """Raise :class:`SettingsError` (naming the key) for what the device cannot do."""
        _check_density(self.density)
        dh, dv = self.density_h, self.density_v
        w = self.window
        if not (isinstance(w, tuple) and len(w) == 4):
            raise SettingsError("window", f"[x, y, width, height], got {w!r}")
        for name, v in zip(("x", "y", "width", "height"), w):
            _int(f"window.{name}", v)
        x, y, width, height = w
        if x < 0 or y < 0 or width < 1 or height < 1:
            raise SettingsError("window", f"x, y ≥ 0 and width, height ≥ 1, got {list(w)}")
        if x + width > dh or y + height > dv:
            raise SettingsError("window", f"inside the {dh} × {dv} grid of density {_density_text(self.density)} "
                                          f"(x + width ≤ {dh}, y + height ≤ {dv}), got {list(w)}")
        if self.scan not in SCANS:
            raise SettingsError("scan", f"one of {', '.join(map(repr, SCANS))}, got {self.scan!r}")
        if self.scan != "frame" and (y % 2 or height % 2):
            raise SettingsError("window", f"an even y and height for a single field (it takes every other line "
                                          f"of the window), got y = {y}, height = {height}")
        for name in ("offset", "gain"):
            v = getattr(self, name)
            _int(name, v)
            if not 0 <= v <= 255:
                raise SettingsError(name, f"0..255 (256 steps), got {v}")
        _int("levels", self.levels)
        if self.levels not in LEVELS:
            raise SettingsError("levels", f"2, 4, 16 or 256 grey levels (1, 2, 4 or 8 bits), got {self.levels}")
        _int("word_bits", self.word_bits)
        if self.word_bits not in WORD_BITS:
            raise SettingsError("word_bits", f"8, 16 or 32 (the parallel output), got {self.word_bits}")
        if self.word_bits % self.bits:
            raise SettingsError("levels", f"a pixel size that divides the {self.word_bits}-bit word, got {self.bits} bits")
        if (width * self.bits) % self.word_bits:
            per_word = self.word_bits // self.bits
            raise SettingsError("window", f"rows of whole {self.word_bits}-bit words: width × {self.bits} bit must be "
                                          f"a multiple of {self.word_bits} (width a multiple of {per_word}), got width {width}")
        _int("shots", self.shots)
        if self.shots < 0:
            raise SettingsError("shots", f"0 (continuous) or a number of frames ≥ 1, got {self.shots}")
        if self.shots * self.frame_bytes > MEMORY_BYTES:
            raise SettingsError("shots", f"{self.shots} frames of {self.frame_bytes} bytes within the "
                                         f"{MEMORY_BYTES // 1024} KiB on-board memory "
                                         f"(at most {MEMORY_BYTES // self.frame_bytes} at these settings)")

    @classmethod
    def from_table(cls, t) -> "GrabberSettings":
        """From a configuration table (:class:`rtctl.tomltable.Table`); errors name file and key."""
        window = t.raw("window", None)
        if window is not None and not (isinstance(window, list) and len(window) == 4):
            raise t.error("window", f"[x, y, width, height], got {window!r}")
        try:
            s = cls(density=t.raw("density", 512), window=None if window is None else tuple(window),
                    scan=t.str("scan", "fields"), offset=t.int("offset", 0), gain=t.int("gain", UNITY_GAIN),
                    levels=t.int("levels", 256), word_bits=t.int("word_bits", 32), shots=t.int("shots", 0))
        except SettingsError as e:
            raise t.error(e.key, e.expected) from None
        t.done()
        return s


def _int(key: str, v) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise SettingsError(key, f"an integer, got {v!r}")


def _check_density(d) -> None:
    """One of the 16 modes: 2^k, or (2^k horizontal, 2^k vertical), k = 6..9."""
    modes = f"2^k with k = 6..9 ({', '.join(map(str, DENSITIES))}), or [horizontal, vertical], each of them"
    if isinstance(d, tuple):
        if len(d) != 2:
            raise SettingsError("density", f"{modes}, got {list(d)!r}")
        for axis, v in zip(("horizontal", "vertical"), d):
            _int(f"density.{axis}", v)
            if v not in DENSITIES:
                raise SettingsError(f"density.{axis}", f"{modes}, got {list(d)}")
        return
    _int("density", d)
    if d not in DENSITIES:
        raise SettingsError("density", f"{modes}, got {d}")


def _density_text(d) -> str:
    return str(d) if not isinstance(d, tuple) else f"[{d[0]}, {d[1]}]"


class LoopClock:
    """A device's CLOCK_MONOTONIC stamps on the loop's clock. The offset between the two is
    the smallest difference seen at a read (monotonic now − loop time t): a read can be late
    for its tick, never early, so the smallest is the truest, and one late read does not move
    every later stamp. (The loop's clock runs with CLOCK_MONOTONIC and never jumps back.)"""

    def __init__(self):
        self.offset_ns = 2 ** 62

    def to_loop(self, t: float, now_ns: int, stamp_ns: int) -> float:
        offset = now_ns - round(t * 1e9)
        if offset < self.offset_ns:
            self.offset_ns = offset
        return (stamp_ns - self.offset_ns) * 1e-9


class Frame:
    """One image as the device delivered it.

    ``words`` are the packed pixels, (rows, words_per_row) of uint8/16/32 — usually a
    zero-copy view of the device's buffer, valid until the device's next new frame (call
    :meth:`copy` to keep one). :meth:`pixels` unpacks them into grey levels 0 … levels − 1.
    ``capture_time`` is on the loop's clock (s): when the (first) field was sampled;
    ``field`` is "odd" or "even" for a single field, "frame" for an interlaced frame.
    """

    __slots__ = ("seq", "capture_time", "field", "settings", "words", "_unpack")

    def __init__(self, seq: int, capture_time: float, field: str, settings: GrabberSettings, words: np.ndarray,
                 unpack):
        self.seq, self.capture_time, self.field, self.settings, self.words = seq, capture_time, field, settings, words
        self._unpack = unpack  # (words, bits, out) → out

    def pixels(self, out: np.ndarray | None = None, rows: slice = slice(None)) -> np.ndarray:
        """Grey levels of the image's ``rows`` as (n, width) uint8; into ``out`` when given
        (no allocation)."""
        s = self.settings
        words = self.words[rows]
        shape = (words.shape[0], s.width)
        if out is None:
            out = np.empty(shape, dtype=np.uint8)
        elif out.shape != shape or out.dtype != np.uint8:
            raise ValueError(f"out must be {shape} uint8, got {out.shape} {out.dtype}")
        return self._unpack(words, s.bits, out)

    def copy(self) -> "Frame":
        return Frame(self.seq, self.capture_time, self.field, self.settings, self.words.copy(), self._unpack)

    def grid_row(self, r: float) -> float:
        """Grid row (0 … density_v − 1) of image row ``r``: a field holds every other line,
        the odd field (TV lines 1, 3, …) the grid's rows 0, 2, …"""
        y = self.settings.window[1]
        if self.field == "frame":
            return y + r
        return y + 2 * r + (self.field == "even")

    def __repr__(self) -> str:
        s = self.settings
        return (f"Frame(seq={self.seq}, t={self.capture_time:.4f}, {self.field} {s.rows}×{s.width} "
                f"@{_density_text(s.density)}, {s.levels} levels in {s.word_bits}-bit words)")


class FrameGrabber(Hardware):
    """Base of framegrabber devices: implement ``_poll(t)`` (fetch the newest complete
    frame into ``self._latest`` without waiting; return True when it is new) and
    ``_send(settings, t)`` (program the device), plus the lifecycle hooks."""

    kind = "framegrabber"

    def __init__(self, name: str, settings: GrabberSettings):
        super().__init__(name)
        self.settings = settings  # what the device runs with (or will, after the next write)
        self._pending: GrabberSettings | None = settings
        self._latest: Frame | None = None
        self._fresh = False
        self.frames = 0  # frames picked up
        self.dropped = 0  # frames the device completed that nobody picked up

    def apply(self, settings: GrabberSettings) -> None:
        """Program new settings; the device takes them at its next field (after ``write``)."""
        if not isinstance(settings, GrabberSettings):
            raise TypeError(f"expected GrabberSettings, got {type(settings).__name__}")
        self.settings = self._pending = settings

    def trigger(self) -> None:
        """Start another burst of ``settings.shots`` frames (N-shot mode)."""
        self._pending = self.settings

    def _read(self, t: float) -> Status:
        if self._poll(t):
            self._fresh = True
        return Status.OK

    def _write(self, t: float) -> Status:
        if self._pending is not None:
            self._send(self._pending, t)
            self._pending = None
        return Status.OK

    def _on_activate(self) -> None:
        self._write(0.0)  # the device starts grabbing as soon as it is programmed

    def grab(self) -> Frame | None:
        """The newest complete frame picked up by ``read`` and not yet handed out, else None."""
        if not self._fresh:
            return None
        self._fresh = False
        return self._latest

    def diagnostics(self) -> dict:
        return {**super().diagnostics(), "frames": self.frames, "dropped": self.dropped,
                "settings": self.settings.__dict__.copy()}

    def _poll(self, t: float) -> bool:
        raise NotImplementedError

    def _send(self, settings: GrabberSettings, t: float) -> None:
        raise NotImplementedError
