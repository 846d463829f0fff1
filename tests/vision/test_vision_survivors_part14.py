"""Tests for vision mutants that survived the fast pass of the restarted full run
(docs/mutation/vision.md, part 14): ``locate``'s output is four float64 numbers, refused
otherwise whatever its type (an ``and`` for an ``or`` let a float64 array of another shape
through to the compiled centroid, which writes four elements); a header's field code that
names no field is refused whatever the scan; a claim that loses every race to the device gives
up after three attempts (docs/framegrabber.md); ``locate`` takes a ``min_contrast`` of 1, and a
box just past an edge of the image finds nothing; a published slot never written holds no
frame and is no error; a camera that looks at its own position is a configuration error
naming ``look_at``; the device writes the slots in turn, going up round the ring; the observer
binds to exactly one framegrabber in-process (before, only the daemon's runs in a subprocess
showed it); any positive focal length is taken; packed words in three dimensions, or of a shape
that does not hold the image in its rows or its width alone, are refused."""
import numpy as np
import pytest

from drivers.protocols.framegrabber import F_FIELD
from rtctl.errors import ProtocolError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.vision.marker import locate
from vision_rig import programmed_pair


@pytest.mark.parametrize("out", [np.zeros(3), np.zeros(5), np.zeros((4, 1)), [0.0] * 4],
                         ids=["3", "5", "4x1", "list"])
def test_locate_refuses_an_out_that_is_not_four_float64s(out):
    img = np.zeros((8, 8), dtype=np.uint8)
    img[3:5, 3:5] = 255
    with pytest.raises(ValueError, match="float64 array of 4"):
        locate(img, (4.0, 4.0), (2, 2), 256, 0.1, out)


@pytest.mark.parametrize("code", [-1, 3, 4, 1 << 40])
@pytest.mark.parametrize("scan", ["frame", "odd", "even", "fields"])
def test_a_field_code_that_names_no_field_is_refused_for_every_scan(scan, code):
    """A header's field code comes from the shared segment: a code that is no field (below 0,
    past the last, huge) is a protocol error naming it, whatever the scan."""
    settings = GrabberSettings(density=64, scan=scan, word_bits=8)
    memory, host, dev, gen, regs = programmed_pair(settings)
    slot = dev.reserve()
    dev.publish(slot, 0, "frame", gen, regs, settings.frame_bytes)
    memory.slot_headers[slot][F_FIELD] = code
    with pytest.raises(ProtocolError, match=f"field code {code}, scan '{scan}'"):
        host.take(0.0, 0)


@pytest.mark.parametrize("races, taken", [(2, True), (3, False)])
def test_a_claim_that_loses_every_race_gives_up_after_three_attempts(monkeypatch, races, taken):
    """docs/framegrabber.md: the host claims at most three times in one tick while the device
    reuses the slot under it, then takes nothing until the next tick (bounded time)."""
    from drivers.protocols import framegrabber_host
    from drivers.protocols.framegrabber import NOTHING, RACE

    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    memory, host, dev, gen, regs = programmed_pair(settings)
    calls = []
    claim = framegrabber_host.host_claim

    def racing(*args):
        calls.append(1)
        return RACE if len(calls) <= races else claim(*args)

    monkeypatch.setattr(framegrabber_host, "host_claim", racing)
    dev.publish(dev.reserve(), 0, "frame", gen, regs, settings.frame_bytes)
    slot = host.claim()
    assert (slot >= 0) is taken and (taken or slot == NOTHING)
    assert len(calls) == min(races + 1, 3)


def test_locate_takes_a_min_contrast_of_one():
    """min_contrast is in (0, 1] (a box from black to white at most): 1 is taken — and, as no
    box can stand a full scale above its own mean, finds nothing."""
    img = np.zeros((8, 8), dtype=np.uint8)
    img[4, 4] = 255
    assert locate(img, (4.0, 4.0), (2, 2), 256, 1.0, np.zeros(4)) is False


@pytest.mark.parametrize("center", [(-3.0, 4.0), (10.0, 4.0), (4.0, -3.0), (4.0, 10.0)],
                         ids=["above", "below", "left", "right"])
def test_a_box_just_past_an_edge_of_the_image_finds_nothing(center):
    """A box of ±2 rows around row −3 ends at row −1 (and around row 10 of an 8-row image
    starts at row 8), and so for columns: no pixel of the image, nothing found — not a
    division by an empty box."""
    img = np.zeros((8, 8), dtype=np.uint8)
    img[::2, ::2] = 255
    assert locate(img, center, (2, 2), 256, 0.1, np.zeros(4)) is False


def test_a_published_slot_never_written_is_no_frame_and_no_error():
    """A published slot whose sequence number is 0 ("never written", as an abandoned slot is
    marked) holds no frame: nothing is taken — not a sequence number gone back, once frames
    have been taken."""
    from drivers.protocols.framegrabber import W_PUBLISHED, W_SEQ0

    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    memory, host, dev, gen, regs = programmed_pair(settings)
    dev.publish(dev.reserve(), 0, "frame", gen, regs, settings.frame_bytes)
    assert host.take(0.0, 0) is not None
    slot = dev.reserve()
    memory.writer[W_SEQ0 + slot] = 0
    memory.writer[W_PUBLISHED] = slot
    assert host.take(0.0, 0) is None


def test_a_camera_looking_at_its_own_position_is_a_configuration_error_naming_look_at():
    from rtctl.errors import ConfigError
    from rtctl.tomltable import Table
    from rtctl.vision.camera import Camera

    place = {"position": [1.0, 0.5, 2.0], "look_at": [1.0, 0.5, 2.0]}
    with pytest.raises(ConfigError) as e:
        Camera.from_table(Table(place, "cell.toml", "camera"))
    assert e.value.key_path.endswith("look_at") and "cell.toml" in str(e.value)


def test_the_device_writes_the_slots_in_turn_going_up_past_those_it_cannot_take():
    """From the slot after its last one, the search goes up round the ring: with slot 2
    published it takes 3 (not 1), and from 3 it wraps to 0."""
    from drivers.protocols.framegrabber import W_PUBLISHED, DevicePort, GrabberMemory, buffer_bytes

    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True)
    dev = DevicePort(memory)
    memory.writer[W_PUBLISHED] = 2
    dev._next = 2
    assert dev.reserve() == 3
    assert dev.reserve() == 0  # (3 is BUSY now: the search wraps)


@pytest.mark.parametrize("devices, bound", [({"cam": "grabber"}, True), ({"cam": "grabber", "other": "grabber"}, False),
                                            ({"cam": "other"}, False)])
def test_an_observer_binds_to_exactly_one_framegrabber_and_nothing_else(devices, bound):
    from rtctl.model import load_robot
    from rtctl.vision.observer import MarkerObserver
    from runtime_helpers import PUMA
    from vision_rig import CAMERA, NthPoll

    grabber = NthPoll(1)
    given = {name: grabber if kind == "grabber" else object() for name, kind in devices.items()}
    observer = MarkerObserver("marker", load_robot(PUMA), CAMERA)
    if bound:
        observer.bind(given)
        assert observer.grabber is grabber
    else:
        with pytest.raises(ValueError, match="exactly one framegrabber device"):
            observer.bind(given)


@pytest.mark.parametrize("focal_px", [1.0, 0.5])
def test_any_positive_focal_length_is_taken(focal_px):
    from rtctl.vision.camera import Camera

    camera = Camera.looking_at([1.0, 0.5, 2.0], [0.0, 0.0, 0.0], focal_px)
    assert camera.focal_px == focal_px


def test_packed_words_in_three_dimensions_are_refused():
    from rtctl.vision.pixels import pack, unpack

    with pytest.raises(ValueError, match="2-D array"):
        unpack(np.zeros((2, 4, 1), dtype=np.uint8), 8, np.zeros((2, 4), dtype=np.uint8))
    with pytest.raises(ValueError, match="2-D array"):
        pack(np.zeros((2, 8), dtype=np.uint8), 1, 8, out=np.zeros((2, 1, 1), dtype=np.uint8))


@pytest.mark.parametrize("rows, words_per_row", [(2, 2), (3, 1), (1, 1)], ids=["wider", "more-rows", "fewer-rows"])
def test_packed_words_that_do_not_hold_the_image_are_refused(rows, words_per_row):
    """Two rows of 32 one-bit pixels are 2 × 1 words of 32 bits: any other shape — wrong in its
    rows or its width alone — is refused before the compiled loop reads past the image."""
    from rtctl.vision.pixels import digitise_pack

    with pytest.raises(ValueError, match="do not hold"):
        digitise_pack(np.zeros((2, 32), dtype=np.float32), 0, 1.0, 2, np.zeros((rows, words_per_row), dtype=np.uint32))
