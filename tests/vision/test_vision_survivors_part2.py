"""Tests for the vision and framegrabber-protocol mutants that survived the suite (part 2, the
s31 sample; docs/mutation/vision.md). Each expectation comes from the documented layout and semantics,
not from what the code returns:

* the WRITER section holds published, written and one sequence word per slot — 18 words for
  16 slots, the last at byte 384 + 8 · 17 (a writer view one word short made the device's
  ``abandon`` of slot 15 raise);
* a freshly created buffer has no host claim and no held slot (−1): a device that runs
  before any host attaches uses every slot, slot 0 first (a claim and hold reset to 0 made it
  avoid slot 0);
* an invalid published slot index names the valid range −1..n_slots − 1 (docs/framegrabber.md:
  "expected -1..3" for four slots);
* ``locate`` refuses a 3-D uint8 image and a 2-D image of another dtype with its own message
  (an ``or`` made ``and`` accepted both);
* the observer's unpacked-rows buffer grows when a frame has more rows than the fields before
  it at the same width (a comparison against the buffer's width let a 32-row buffer serve a
  64-row frame);
* ``digitise_pack`` puts the words' bytes in little-endian order, the documented examples
  worked out by hand (a byte flip of ``word_bits // 9 − 1`` reversed or swapped them).
"""
import numpy as np
import pytest

from drivers.protocols.framegrabber import (
    BUSY, MAX_SLOTS, MIN_SLOTS, W_PUBLISHED, DevicePort, GrabberMemory, buffer_bytes)
from drivers.protocols.framegrabber_host import HostPort
from rtctl.errors import ProtocolError
from rtctl.hal.framegrabber import Frame, GrabberSettings
from rtctl.model import load_robot
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from rtctl.vision.pixels import digitise_pack, unpack
from runtime_helpers import PUMA
from vision_rig import CAMERA

WRITER_BYTE = 384  # the module docstring's layout: WRITER (published slot, written, slot_seq[n_slots])


def _words(buffer) -> np.ndarray:
    """The buffer as the documented little-endian int64 words (independent of the views)."""
    return np.frombuffer(buffer, dtype="<i8")


def _seq_word(s: int) -> int:
    return WRITER_BYTE // 8 + 2 + s


# -- the writer's words ------------------------------------------------------------------------

def test_every_slot_of_a_sixteen_slot_buffer_can_be_reserved_and_abandoned():
    """With MAX_SLOTS = 16 slots the device reserves each slot in turn (its sequence word, at
    byte 384 + 8 · (2 + s), is BUSY meanwhile) and gives it back unpublished (0 again) — the
    last one, slot 15, at byte 384 + 8 · 17 included."""
    assert MAX_SLOTS == 16
    buffer = np.zeros(buffer_bytes(MAX_SLOTS), dtype=np.uint8)
    memory = GrabberMemory(buffer, create=True, n_slots=MAX_SLOTS)
    dev, words = DevicePort(memory), _words(buffer)
    for s in range(MAX_SLOTS):
        slot = dev.reserve()
        assert slot == s
        assert words[_seq_word(s)] == BUSY
        dev.abandon(slot)
        assert words[_seq_word(s)] == 0
    assert dev.skipped == 0


def test_a_frame_in_the_last_of_sixteen_slots_is_published_and_taken():
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    buffer = np.zeros(buffer_bytes(MAX_SLOTS), dtype=np.uint8)
    memory = GrabberMemory(buffer, create=True, n_slots=MAX_SLOTS)
    host = HostPort(memory)
    host.program(settings)
    dev, words = DevicePort(memory), _words(buffer)
    gen, regs = dev.registers()
    for s in range(MAX_SLOTS):
        slot = dev.reserve()
        dev.publish(slot, 0, "frame", gen, regs, settings.frame_bytes)
        assert slot == s and words[_seq_word(s)] == s + 1 and words[WRITER_BYTE // 8 + W_PUBLISHED] == s
        frame = host.take(0.0, 0)
        assert frame is not None and frame.seq == s + 1
    assert host.read == MAX_SLOTS and host.dropped == 0
    assert memory.writer[2 + MAX_SLOTS - 1] == MAX_SLOTS  # slot 15's sequence word, through the view


# -- a fresh buffer: no claim, no hold ----------------------------------------------------------

@pytest.mark.parametrize("n_slots", [MIN_SLOTS, MIN_SLOTS + 1])
def test_a_device_before_any_host_uses_every_slot_from_slot_0(n_slots):
    """Nobody claims or holds a slot of a buffer just created (a simulator creates it and its
    camera runs before a host attaches): only the published slot is excluded, so the device
    goes round all of them, 0, 1, …, n − 1, 0, …"""
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    memory = GrabberMemory(np.zeros(buffer_bytes(n_slots), dtype=np.uint8), create=True, n_slots=n_slots)
    dev, used = DevicePort(memory), []
    for _ in range(2 * n_slots):
        slot = dev.reserve()
        used.append(slot)
        dev.publish(slot, 0, "frame", 2, [0] * 13, settings.frame_bytes)
    assert used == list(range(n_slots)) * 2
    assert dev.skipped == 0


def test_a_host_attaching_to_a_running_device_takes_its_frame_in_slot_0():
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True)
    dev = DevicePort(memory)
    slot = dev.reserve()  # before the host: slot 0 is free
    assert slot == 0
    host = HostPort(memory)
    host.program(settings)
    gen, regs = dev.registers()
    dev.publish(slot, 0, "frame", gen, regs, settings.frame_bytes)
    frame = host.take(0.0, 0)
    assert frame is not None and frame.seq == 1 and host.claim() == -1


# -- the published slot index's message ---------------------------------------------------------

@pytest.mark.parametrize(("n_slots", "bad"), [(4, 4), (4, -2), (16, 16), (5, 1 << 40)])
def test_an_invalid_published_slot_names_the_valid_range(n_slots, bad):
    """docs/framegrabber.md: "published slot index 1099511627776, expected -1..3" (four slots)."""
    memory = GrabberMemory(np.zeros(buffer_bytes(n_slots), dtype=np.uint8), create=True, n_slots=n_slots)
    host = HostPort(memory)
    memory.writer[W_PUBLISHED] = bad
    with pytest.raises(ProtocolError) as e:
        host.claim()
    assert str(e.value) == f"published slot index {bad}, expected -1..{n_slots - 1}"


# -- locate's input check -----------------------------------------------------------------------

@pytest.mark.parametrize("img", [
    np.zeros((8, 8, 1), dtype=np.uint8),  # uint8, but 3-D
    np.zeros((8, 8, 3), dtype=np.uint8),
    np.zeros((8, 8), dtype=np.float64),  # 2-D, but not uint8
    np.zeros((8, 8), dtype=np.uint16),
    np.zeros((8, 8), dtype=np.int8),
    np.zeros(64, dtype=np.uint8),  # 1-D uint8
], ids=["3d-u8-1", "3d-u8-3", "2d-f64", "2d-u16", "2d-i8", "1d-u8"])
def test_locate_takes_only_a_2d_uint8_image(img):
    img.reshape(-1)[36] = 100  # a marker, so that nothing else could make it refuse
    with pytest.raises(ValueError, match=r"img must be a 2-D uint8 array, got \(.*\) "):
        locate(img, (4.0, 4.0), (2, 2), 256, 0.1, np.zeros(4))


def test_locate_takes_the_same_image_as_2d_uint8():
    img = np.zeros((8, 8), dtype=np.uint8)
    img[4, 5] = 200
    out = np.zeros(4)
    assert locate(img, (4.0, 4.0), (2, 2), 256, 0.1, out)
    # 25 pixels, mean 8, threshold ½(200 + 8) = 104: one pixel of weight 96 at (4, 5)
    np.testing.assert_array_equal(out, [4.0, 5.0, 96.0, 1.0])


# -- the observer's unpacked rows ---------------------------------------------------------------

def test_the_observer_finds_a_marker_in_a_frame_taller_than_the_fields_before_it():
    """An odd field of density 64 is 32 rows × 64 columns, a frame 64 × 64: the same width.
    With search_px = 160 screen px the box is ±ceil(160 · 64 / 512) = ±20 image rows in a frame
    (±10 in a field): 41 rows, more than the field had. A single bright pixel is found at its
    own grid position in both."""
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA, search_px=160.0)
    out = np.zeros(2)

    field = GrabberSettings(density=64, scan="odd", word_bits=8)
    assert (field.rows, field.width) == (32, 64)
    words = np.zeros((field.rows, field.words_per_row), dtype=np.uint8)
    words[10, 30] = 250  # odd field: image row 10 is grid row 20
    guess = Camera.to_screen(np.array([30.0, 20.0]), field.density)
    assert observer.measure(Frame(1, 0.0, "odd", field, words, unpack), guess, out)
    np.testing.assert_allclose(Camera.to_grid(out, field.density), [30.0, 20.0], atol=1e-9)

    frame = GrabberSettings(density=64, scan="frame", word_bits=8)
    assert (frame.rows, frame.width) == (64, 64)
    words = np.zeros((frame.rows, frame.words_per_row), dtype=np.uint8)
    words[40, 30] = 250
    guess = Camera.to_screen(np.array([30.0, 40.0]), frame.density)  # box rows 20 … 60
    assert observer.measure(Frame(2, 0.0, "frame", frame, words, unpack), guess, out)
    np.testing.assert_allclose(Camera.to_grid(out, frame.density), [30.0, 40.0], atol=1e-9)


# -- digitise_pack's byte order -----------------------------------------------------------------

def _analog(codes, levels) -> np.ndarray:
    """Video levels in the middle of each code's step: (p + ½) / L, exact in float32."""
    return ((np.array([codes], dtype=np.float64) + 0.5) / levels).astype(np.float32)


@pytest.mark.parametrize(("codes", "levels", "word_bits", "words", "memory"), [
    # docs/framegrabber.md, "Bit order": the first pixel in the most significant bits, words little-endian
    ([1, 2, 3, 4, 5, 6, 7, 8], 16, 32, [0x12345678], [0x78, 0x56, 0x34, 0x12]),
    ([0x11, 0x22, 0x33, 0x44], 256, 32, [0x11223344], [0x44, 0x33, 0x22, 0x11]),
    ([3, 0, 1, 2], 4, 8, [0xC6], [0xC6]),
    ([1] + [0] * 14 + [1], 2, 16, [0x8001], [0x01, 0x80]),
    # several words in a row: each word's bytes in order, the words in order
    ([1, 2, 3, 4, 5, 6], 16, 8, [0x12, 0x34, 0x56], [0x12, 0x34, 0x56]),
    ([0xAB, 0xCD, 0x01, 0x02], 256, 16, [0xABCD, 0x0102], [0xCD, 0xAB, 0x02, 0x01]),
    ([0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88], 256, 32, [0x11223344, 0x55667788],
     [0x44, 0x33, 0x22, 0x11, 0x88, 0x77, 0x66, 0x55]),
])
def test_digitise_pack_makes_the_documented_words(codes, levels, word_bits, words, memory):
    dtype = np.dtype(f"<u{word_bits // 8}")
    out = np.zeros((1, len(words)), dtype=dtype)
    digitise_pack(_analog(codes, levels), 0, 1.0, levels, out)
    assert [int(w) for w in out[0]] == words
    assert out.view(np.uint8).reshape(-1).tolist() == memory


def test_digitise_pack_rows_stay_in_their_rows():
    """Two rows of two 8-bit words (4-bit pixels): row 0 holds 0x12 0x34, row 1 0x56 0x78."""
    out = np.zeros((2, 2), dtype=np.uint8)
    analog = ((np.arange(1, 9, dtype=np.float64).reshape(2, 4) + 0.5) / 16).astype(np.float32)
    digitise_pack(analog, 0, 1.0, 16, out)
    assert out.tolist() == [[0x12, 0x34], [0x56, 0x78]]
