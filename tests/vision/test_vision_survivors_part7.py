"""Tests for vision mutants that survived the full run's fast pass (part 7; docs/mutation/vision.md).
Each expectation is the documented wire (docs/framegrabber.md, the protocol's module docstring):

* a slot's sequence number may advance over the last frame taken by at most 2^20: a jump of
  exactly 2^20 is a frame, one more is a ProtocolError naming both numbers;
* a frame taken with a register generation this host never programmed is refused — 0 (none
  yet), an odd one (being written) or one past the newest;
* the host's words are where the layout puts them: READER at byte 640 (claim, hold, read,
  dropped, last_seq), read as raw little-endian words;
* the marker observer's ``history`` is 4 … 100 000 ticks, both ends included.
"""
import numpy as np
import pytest

from rtctl.errors import ConfigError, ProtocolError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.model import load_robot
from runtime_helpers import PUMA
from vision_rig import observer_config, programmed_pair

SETTINGS = GrabberSettings(density=64, scan="frame", word_bits=8)
MAX_JUMP = 2 ** 20  # docs/framegrabber.md: "advances over the last frame taken (by at most 2^20)"
READER_BYTE = 640


def _publish(dev, gen, regs, seq_before):
    """Publish a frame whose sequence number is ``seq_before + 1``."""
    dev.seq = seq_before
    slot = dev.reserve()
    return dev.publish(slot, 0, "frame", gen, regs, SETTINGS.frame_bytes)


def test_a_sequence_number_may_jump_by_two_to_the_twentieth_and_no_more():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    seq = _publish(dev, gen, regs, MAX_JUMP - 1)
    assert seq == MAX_JUMP
    assert host.take(0.0, 0).seq == MAX_JUMP  # 2^20 after the 0 the host attached at
    host.release()
    assert host.take(0.0, 0) is None and _publish(dev, gen, regs, MAX_JUMP + 4) == MAX_JUMP + 5
    assert host.take(0.0, 0).seq == MAX_JUMP + 5  # 5 after the last taken: the jump, not the number
    host.release()
    bad = _publish(dev, gen, regs, 2 * MAX_JUMP + 5)
    with pytest.raises(ProtocolError, match=f"jumped from {MAX_JUMP + 5} to {bad}"):
        host.take(0.0, 0)


@pytest.mark.parametrize("offset, why", [(-2, "no generation yet"), (-1, "odd: being written"),
                                         (2, "past the newest")])
def test_a_frame_of_a_register_generation_never_programmed_is_refused(offset, why):
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    assert gen == 2  # one programming: generation 0 before it, 1 while it was written
    bad = gen + offset
    _publish(dev, bad, regs, 0)  # the registers themselves are valid settings
    with pytest.raises(ProtocolError, match=f"register generation {bad} was never programmed"):
        host.take(0.0, 0)


def test_the_hosts_words_are_at_byte_640():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    _publish(dev, gen, regs, 0)
    _publish(dev, gen, regs, 3)  # frame 4: the host never took frames 1-3
    frame = host.take(0.0, 0)
    words = np.frombuffer(memory.buffer, dtype="<i8")[READER_BYTE // 8: READER_BYTE // 8 + 5]
    claim, hold, read, dropped, last_seq = words.tolist()
    assert frame.seq == 4
    assert (claim, hold, read, dropped, last_seq) == (-1, 1, 1, 3, 4)  # frame 4 went into slot 1


@pytest.mark.parametrize("history, refused", [(4, None), (100_000, None), (3, "≥ 4"), (100_001, "≤ 100000")])
def test_the_observers_history_holds_4_to_100000_ticks(tmp_path, history, refused):
    from rtctl.vision.observer import MarkerObserver

    _, c = observer_config(tmp_path, f"history = {history}")
    if refused is None:
        MarkerObserver.from_config(c, load_robot(PUMA))
    else:
        with pytest.raises(ConfigError, match=f"{refused}, got {history}") as e:
            MarkerObserver.from_config(c, load_robot(PUMA))
        assert e.value.key_path.endswith("history")
