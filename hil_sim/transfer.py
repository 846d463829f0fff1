"""The simulated card's transfer into the host's memory, at the card's rate (docs/framegrabber.md).

The paper's interface moves the digitised picture into memory at up to 13 MB/s (§2) while it
scans, "quietly", beside the host (§5), and has a 256 × 512 field in memory within 20 ms
(§1). The model:

* **PAL timing.** A field lasts 20 ms. Its 288 picture lines of 64 µs come first
  (18.432 ms) and the vertical blanking follows. The v/2 grid lines of a field at vertical
  density v are spread evenly over those picture lines. The bytes of a grid line are ready
  once the line has been scanned, so line ℓ of a field is ready (ℓ + 1) · 18.432 ms / (v/2)
  after the field starts.
* **One channel at the card's rate R.** Bytes leave in the order they become ready, one
  image after the other. This is a fluid queue. An image's last byte is moved at

      T = max( max_k (a_k + S_k / R),  T_previous + B / R )

  where a_k are the times its rows become ready, S_k is the bytes of the rows ready at or
  after a_k, B is the image's bytes and T_previous is when the previous image's last byte
  was moved.
* **Hand-over.** The card hands an image over at the end of its last field (the field sync
  ends it) or when its transfer ends, whichever comes later.

At 13 MB/s every one of the 16 modes is moved before its field ends. The busiest mode,
512 × 512 at 8 bits, produces 512 bytes every 72 µs (7.1 MB/s). So at the paper's rate an
image is readable when its last field ends. A slower card delays the hand-over. A card
slower than the picture falls behind: its images wait for free slots and some are skipped.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.hal.framegrabber import FIELD_NS, GrabberSettings

LINE_NS = 64_000  # PAL line period
PICTURE_LINES = 288  # picture lines a field (625-line PAL: 576 a frame); the rest of the 312.5 is blanking
PICTURE_NS = PICTURE_LINES * LINE_NS  # 18.432 ms
PAPER_MB_S = 13.0  # the paper's transfer rate (§2), in 10^6 bytes a second


def rows_ready_ns(settings: GrabberSettings) -> np.ndarray:
    """When each image row's bytes are ready, in ns from the start of the image's (first) field."""
    if not isinstance(settings, GrabberSettings):
        raise TypeError(f"expected GrabberSettings, got {type(settings).__name__}")
    _, y, _, height = settings.window
    line_ns = PICTURE_NS / (settings.density_v // 2)
    if settings.scan != "frame":  # a field: image row i is the field's line y/2 + i
        return (y // 2 + np.arange(settings.rows) + 1) * line_ns
    # a frame: grid row g is line g // 2 of the odd field (g even) or of the even field, 20 ms later
    grid_rows = np.arange(y, y + height)
    return (grid_rows % 2) * FIELD_NS + (grid_rows // 2 + 1) * line_ns


class TransferChannel:
    """The card's one channel into memory: when each image becomes readable."""

    def __init__(self, rate_mb_s: float = PAPER_MB_S):
        if isinstance(rate_mb_s, bool) or not isinstance(rate_mb_s, (int, float)) or not (
                0 < rate_mb_s < math.inf):
            raise ValueError(f"transfer rate: a positive, finite number of MB/s, got {rate_mb_s!r}")
        self.ns_per_byte = 1e3 / rate_mb_s  # 10^6 bytes a second: 1000/rate ns a byte
        self.end_ns = -(1 << 62)  # when the last byte of the previous image was moved

    def plan(self, settings: GrabberSettings) -> tuple[float, float, int]:
        """(its transfer's end after its start if the channel is free, its bytes' transfer time,
        its scan time) in ns for images of ``settings``: worked out once per settings."""
        ready = np.sort(rows_ready_ns(settings))
        row_bytes = settings.frame_bytes // settings.rows
        bytes_from = (ready.size - np.arange(ready.size)) * row_bytes  # S_k: bytes ready at or after a_k
        tail = float(np.max(ready + bytes_from * self.ns_per_byte))
        fields = 2 if settings.scan == "frame" else 1
        return tail, settings.frame_bytes * self.ns_per_byte, fields * FIELD_NS

    def readable_ns(self, start_ns: int, plan: tuple[float, float, int]) -> int:
        """An image whose (first) field started at ``start_ns`` has been scanned: when it is
        readable. Its transfer takes the channel until its end."""
        tail, busy, scan = plan
        self.end_ns = math.ceil(max(start_ns + tail, self.end_ns + busy))
        return max(start_ns + scan, self.end_ns)
