"""Tests for the vision and framegrabber-protocol mutants that survived the suite (part 3, the
full run; docs/mutation/vision.md). Each expectation comes from the documented layout and limits:

* a buffer is a framegrabber buffer only if it is at least the 4 KiB header long *and* starts
  with the magic — either alone is refused with a ProtocolError (an ``and`` accepted a
  full-sized buffer with any magic, and let a short one fail on a view instead);
* the host checks exactly the identity words at every poll — the magic and the six layout
  words (version … field period), words 0–6 — and not the layout section's spare words
  (one more word checked turned a spare word into "the device restarted");
* a CLOCK_MONOTONIC capture stamp may lead the host's "now" by up to 1 ms, no more;
* the marker observer's ``min_contrast`` is a fraction of full scale, at most 1, and 0.2 by
  default: a box whose brightest pixel stands 45 levels above its mean holds no marker, one of
  60 levels does;
* the search box reaches the image's first row.
"""
import types

import numpy as np
import pytest

from drivers.protocols import framegrabber_host
from drivers.protocols.framegrabber import HEADER_BYTES, MAGIC, DevicePort, GrabberMemory, buffer_bytes
from drivers.protocols.framegrabber_host import HostPort
from rtctl.errors import ConfigError, ProtocolError
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import load_robot
from rtctl.vision.camera import Camera
from rtctl.vision.pixels import unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, observer_config

SETTINGS = GrabberSettings(density=64, scan="frame", word_bits=8)
IDENT = 7  # the module docstring's layout: the magic (word 0), then version … field_ns (words 1–6)
LAYOUT_END = 128  # the LAYOUT section ends where the REGISTERS begin (byte 128)


# -- the magic and the header's size ---------------------------------------------------------------

def test_a_full_sized_buffer_without_the_magic_is_refused():
    buffer = np.zeros(buffer_bytes(), dtype=np.uint8)
    GrabberMemory(buffer, create=True)
    GrabberMemory(buffer)  # (a valid one attaches)
    buffer[0] ^= 0x20  # "rTCTLFG1"
    with pytest.raises(ProtocolError, match="not a framegrabber buffer"):
        GrabberMemory(buffer)


def test_a_buffer_shorter_than_the_header_is_refused_even_with_the_magic():
    buffer = np.zeros(HEADER_BYTES - 8, dtype=np.uint8)
    buffer[:8] = np.frombuffer(MAGIC, dtype=np.uint8)
    with pytest.raises(ProtocolError, match="not a framegrabber buffer"):
        GrabberMemory(buffer)


# -- the identity words checked at every poll -----------------------------------------------------

def _attached():
    buffer = np.zeros(buffer_bytes(), dtype=np.uint8)
    memory = GrabberMemory(buffer, create=True)
    host = HostPort(memory)
    host.program(SETTINGS)
    return np.frombuffer(buffer, dtype="<i8"), memory, host


@pytest.mark.parametrize("word", range(IDENT))
def test_a_changed_identity_word_is_a_protocol_error_naming_it(word):
    words, _, host = _attached()
    before = int(words[word])
    words[word] = before + 1
    with pytest.raises(ProtocolError, match=f"^layout word {word} changed from {before} to {before + 1} "):
        host.claim()


@pytest.mark.parametrize("word", range(IDENT, LAYOUT_END // 8))
def test_the_layout_sections_spare_words_are_not_checked(word):
    words, memory, host = _attached()
    words[word] = -12345
    dev = DevicePort(memory)
    gen, regs = dev.registers()
    slot = dev.reserve()
    dev.publish(slot, 0, "frame", gen, regs, SETTINGS.frame_bytes)
    frame = host.take(0.0, 0)
    assert frame is not None and frame.seq == 1


# -- the capture stamp's lead over "now" ------------------------------------------------------------

NOW_NS = 5_000_000_000


@pytest.mark.parametrize(("lead_ns", "accepted"), [(0, True), (1_000_000, True), (1_000_001, False)])
def test_a_monotonic_capture_stamp_may_lead_now_by_one_millisecond(monkeypatch, lead_ns, accepted):
    monkeypatch.setattr(framegrabber_host, "time", types.SimpleNamespace(monotonic_ns=lambda: NOW_NS))
    _, memory, host = _attached()
    dev = DevicePort(memory)
    gen, regs = dev.registers()
    slot = dev.reserve()
    dev.publish(slot, NOW_NS + lead_ns, "frame", gen, regs, SETTINGS.frame_bytes)
    if accepted:
        assert host.take(0.0, NOW_NS).seq == 1
    else:
        with pytest.raises(ProtocolError, match=f"capture time {NOW_NS + lead_ns} ns .* after now"):
            host.take(0.0, NOW_NS)


# -- the marker observer's contrast and box ---------------------------------------------------------

@pytest.mark.parametrize("value", ["1.5", "0.0", "-0.2"])
def test_min_contrast_is_a_fraction_of_full_scale(tmp_path, value):
    from rtctl.vision.observer import MarkerObserver

    _, c = observer_config(tmp_path, f"min_contrast = {value}")
    with pytest.raises(ConfigError) as e:
        MarkerObserver.from_config(c, load_robot(PUMA))
    assert e.value.key_path.endswith("min_contrast")


def _frame_with(row: int, col: int, background: int, peak: int) -> Frame:
    words = np.full((SETTINGS.rows, SETTINGS.words_per_row), background, dtype=np.uint8)
    words[row, col] = peak
    return Frame(1, 0.0, "frame", SETTINGS, words, unpack)


@pytest.mark.parametrize(("rise", "found"), [(45, False), (60, True)])
def test_the_default_min_contrast_is_a_fifth_of_full_scale(tmp_path, rise, found):
    """search_px = 32 at density 64: a box of ±ceil(32 · 64 / 512) = ±4 pixels, 81 in all. One
    pixel ``rise`` levels above a background of 100 stands rise · 80/81 above the box's mean:
    44.4 < 0.2 · 255 = 51 is no marker, 59.3 is."""
    from rtctl.vision.observer import MarkerObserver

    _, c = observer_config(tmp_path)
    observer = MarkerObserver.from_config(c, load_robot(PUMA))
    out = np.zeros(2)
    guess = Camera.to_screen(np.array([30.0, 40.0]), SETTINGS.density)
    assert observer.measure(_frame_with(40, 30, 100, 100 + rise), guess, out) == found
    if found:
        np.testing.assert_allclose(Camera.to_grid(out, SETTINGS.density), [30.0, 40.0], atol=1e-9)


@pytest.mark.parametrize("guess_row", [0.0, 1.0, 2.0])
def test_the_search_box_reaches_the_first_image_row(guess_row):
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    out = np.zeros(2)
    guess = Camera.to_screen(np.array([30.0, guess_row]), SETTINGS.density)
    assert observer.measure(_frame_with(0, 30, 10, 250), guess, out)
    np.testing.assert_allclose(Camera.to_grid(out, SETTINGS.density), [30.0, 0.0], atol=1e-9)
