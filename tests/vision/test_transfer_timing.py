"""The simulated card's transfer at its rate, timed on the simulator's own (lock-step) clock.

The reference is written here from the model's statement, not from the code. A PAL field is
20 ms and its 288 picture lines of 64 µs come first. The v/2 grid lines of a field are spread
evenly over them, and a line's bytes are ready once it has been scanned. The card moves rows
one at a time at R bytes a second, in the order they are ready, one image after the other.
A row therefore leaves at max(its ready time, the previous row's departure) + its bytes / R
(Lindley's recursion; the code uses the closed-form maximum). The image can be read at the end
of its last field, or when its last row has left if that is later.
"""
import itertools

import numpy as np
import pytest

from rtctl.hal.framegrabber import GrabberSettings
from vision_rig import Rig

FIELD = 0.020
PICTURE = 288 * 64e-6  # s: the picture lines of a field
MODES = list(itertools.product((64, 128, 256, 512), repeat=2))


def ready_times(s: GrabberSettings) -> list[float]:
    """When each image row is scanned, from the start of the image's first field (s)."""
    x, y, w, h = s.window
    line = PICTURE / (s.density_v // 2)
    if s.scan == "frame":  # frame row i is grid row y + i: even grid rows in the odd (first) field
        return sorted((g % 2) * FIELD + (g // 2 + 1) * line for g in range(y, y + h))
    return [(y // 2 + i + 1) * line for i in range(h // 2)]


def readable_times(settings, starts, rate_bytes_s) -> list[float]:
    """Lindley's recursion over the rows of the images started at ``starts``, one after another."""
    row_bytes = settings.frame_bytes / settings.rows
    scan = 2 * FIELD if settings.scan == "frame" else FIELD
    free, out = -1.0, []
    for start in starts:
        for a in ready_times(settings):
            free = max(free, start + a) + row_bytes / rate_bytes_s
        out.append(max(start + scan, free))
    return out


@pytest.mark.parametrize("h, v", MODES)
def test_at_the_papers_13_mb_s_every_mode_is_in_memory_when_its_last_field_ends(h, v):
    for scan, latency in (("fields", FIELD), ("frame", 2 * FIELD)):
        settings = GrabberSettings(density=(h, v), scan=scan, levels=256, word_bits=8)
        # the reference: the transfer ends within the field (the paper's "a field in 20 ms")
        assert readable_times(settings, [0.0], 13e6) == [latency]
        got = Rig(settings, ticks_per_field=20, transfer_mb_s=13.0).frames(0.1)
        assert len(got) == (4 if scan == "fields" else 2)  # ticks 0 … 99 ms
        np.testing.assert_allclose([t - f.capture_time for t, f in got], latency, atol=1e-9)


TICK = FIELD / 200  # 0.1 ms ticks: the hand-over is seen within a tick


@pytest.mark.parametrize("settings, rate_mb_s", [
    # one field every 40 ms, 128 KiB at 6 MB/s: 21.8 ms, longer than the field (no queue)
    (GrabberSettings(density=512, scan="odd", levels=256, word_bits=8), 6.0),
    # the paper's 256 × 256 field, 4-bit pixels in 16-bit words at 1.5 MB/s: 21.8 ms a field
    # every 20 ms: the channel falls behind and the images queue
    (GrabberSettings(density=(256, 512), scan="fields", levels=16, word_bits=16), 1.5),
    # interlaced 512 × 512 frames at 6 MB/s: 43.7 ms a frame every 40 ms (queueing)
    (GrabberSettings(density=512, scan="frame", levels=256, word_bits=8), 6.0),
    # a window's rows: a band in the middle of a (128, 256) grid, frames
    (GrabberSettings(density=(128, 256), window=(32, 61, 64, 130), scan="frame", levels=256, word_bits=8), 0.2),
])
def test_a_slow_card_hands_each_image_over_when_its_transfer_ends(settings, rate_mb_s):
    rig = Rig(settings, ticks_per_field=200, transfer_mb_s=rate_mb_s)
    camera, reserve, overwritten = rig.camera, rig.camera.port.reserve, []

    def reserve_checked():  # a slot whose image is still in transfer is never written again
        slot = reserve()
        overwritten.extend(slot for image in camera.in_transfer if image.slot == slot)
        return slot

    camera.port.reserve = reserve_checked
    got = rig.frames(0.6)
    assert not overwritten
    starts = [f.capture_time for _, f in got]  # lock-step: an image's first field starts at its capture
    expected = readable_times(settings, starts, rate_mb_s * 1e6)
    arrivals = np.array([t for t, _ in got])
    late = arrivals - np.array(expected)
    assert late.min() >= -1e-9 and late.max() < TICK + 1e-9  # at the first tick at or after the reference
    scan = 2 * FIELD if settings.scan == "frame" else FIELD
    assert max(expected[i] - starts[i] for i in range(len(got))) > scan + TICK  # the transfer did delay
    assert [f.seq for _, f in got] == list(range(1, len(got) + 1))  # in order; none lost once scanned
