"""Tests for vision mutants that survived the full run's fast pass (part 10; docs/mutation/vision.md).
Each expectation is the documented wire (the protocol's module docstring, docs/framegrabber.md):

* the wire's version word is 2 and the STATUS section starts at byte 256, read as raw words;
* a device state outside IDLE … FAULT (0 … 3) is a ProtocolError naming it;
* a buffer is made for 4 … 16 slots only, and only in enough bytes;
* on the loop's clock a capture stamp may not lead the host's tick time at all: 1 ns later is
  refused (the 1 ms lead is for CLOCK_MONOTONIC stamps only);
* a frame the host releases is free for the device again;
* a count word (frames written) must be below 2^62: 2^62 itself is refused;
* the observer's search box reaches ±32 screen pixels by default.
"""
import numpy as np
import pytest

from drivers.protocols.framegrabber import (CLOCK_LOOP, RUNNING, S_STATE, W_WRITTEN, DevicePort, GrabberMemory,
                                            buffer_bytes)
from drivers.protocols.framegrabber_host import HostPort
from rtctl.errors import ProtocolError
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import load_robot
from rtctl.vision.camera import Camera
from rtctl.vision.pixels import unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA, programmed_pair

SETTINGS = GrabberSettings(density=64, scan="frame", word_bits=8)


def _raw(memory, byte):
    return int(np.frombuffer(memory.buffer, dtype="<i8")[byte // 8])


def test_the_version_is_2_and_the_status_words_start_at_byte_256():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    assert _raw(memory, 8) == 2  # LAYOUT: version first, after the 8-byte magic
    dev.set_status(RUNNING, applied_gen=gen, error=5)
    assert [_raw(memory, 256 + 8 * k) for k in range(3)] == [RUNNING, gen, 5]  # state, applied_gen, error


@pytest.mark.parametrize("state", [-1, 4, 2 ** 40])
def test_a_device_state_out_of_range_is_refused_by_name(state):
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    memory.status[S_STATE] = state
    with pytest.raises(ProtocolError, match=f"device state {state}, expected 0..3"):
        host.take(0.0, 0)


@pytest.mark.parametrize("n_slots", [3, 17, 0])
def test_a_buffer_is_made_for_4_to_16_slots_only(n_slots):
    buffer = np.zeros(buffer_bytes(16) + 4096, dtype=np.uint8)  # room enough for any of them
    with pytest.raises(ProtocolError, match=f"{n_slots} slots need"):
        GrabberMemory(buffer, create=True, n_slots=n_slots)


def test_a_buffer_is_made_only_in_enough_bytes():
    with pytest.raises(ProtocolError, match="4 slots need"):
        GrabberMemory(np.zeros(buffer_bytes(4) - 1, dtype=np.uint8), create=True, n_slots=4)


@pytest.mark.parametrize("lead_ns, accepted", [(0, True), (1, False)])
def test_a_loop_clock_stamp_may_not_lead_the_tick(lead_ns, accepted):
    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
    host = HostPort(memory)
    host.program(SETTINGS)
    dev = DevicePort(memory)
    gen, regs = dev.registers()
    dev.publish(dev.reserve(), 1_000_000_000 + lead_ns, "frame", gen, regs, SETTINGS.frame_bytes)
    if accepted:
        assert host.take(1.0, 0).capture_time == 1.0
    else:
        with pytest.raises(ProtocolError, match="after now"):
            host.take(1.0, 0)


def test_a_released_frame_is_free_for_the_device():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    for _ in range(3):
        dev.publish(dev.reserve(), 0, "frame", gen, regs, SETTINGS.frame_bytes)  # slots 0, 1, 2
    assert host.take(0.0, 0).seq == 3  # held: slot 2, still the published one
    host.release()
    dev = DevicePort(memory)  # (a new end's search starts at slot 0)
    assert [dev.reserve() for _ in range(4)] == [0, 1, 3, -1]  # every slot but the published one


@pytest.mark.parametrize("written, refused", [(2 ** 62 - 1, False), (2 ** 62, True), (0, False), (-1, True)])
def test_a_count_word_stays_below_two_to_the_62(written, refused):
    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True)
    memory.writer[W_WRITTEN] = written
    if refused:
        with pytest.raises(ProtocolError, match=f"frames written {written}, expected 0 ≤ it < 2\\^62"):
            HostPort(memory)
    else:
        assert HostPort(memory).written == 0


@pytest.mark.parametrize("offset, found", [(32, True), (33, False)])
def test_the_search_box_reaches_32_screen_pixels_by_default(offset, found):
    """At density 512 a screen pixel is an image pixel: a marker 32 columns from the guess is
    in the default box, one 33 columns away is not."""
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    settings = GrabberSettings(density=512, scan="frame", word_bits=8)
    words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
    words[200, 100 + offset] = 250
    out = np.zeros(2)
    guess = Camera.to_screen(np.array([100.0, 200.0]), settings.density)
    assert observer.measure(Frame(1, 0.0, "frame", settings, words, unpack), guess, out) is found
