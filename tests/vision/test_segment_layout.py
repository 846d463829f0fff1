"""The shared segment's bytes are where drivers/protocols/framegrabber.py's module docstring
says they are — the wire a device written elsewhere (in C, say) would follow. Each word is
read back from the raw bytes at its documented offset, not through the module's own views."""
import numpy as np

from drivers.protocols.framegrabber import CLOCK_MONOTONIC, DevicePort, GrabberMemory, buffer_bytes
from drivers.protocols.framegrabber_host import HostPort
from rtctl.hal.framegrabber import FIELD_PERIOD_S, MEMORY_BYTES, GrabberSettings

SETTINGS = GrabberSettings(density=(256, 128), window=(16, 48, 96, 64), scan="odd", offset=3, gain=140, levels=16,
                           word_bits=16, shots=5)


def word(raw: np.ndarray, offset: int) -> int:
    return int(raw[offset:offset + 8].view("<i8")[0])


def test_every_word_of_the_segment_is_at_its_documented_offset():
    raw = np.zeros(buffer_bytes(4), dtype=np.uint8)
    memory = GrabberMemory(raw, create=True, n_slots=4, clock=CLOCK_MONOTONIC)
    host = HostPort(memory)
    host.program(SETTINGS)
    dev = DevicePort(memory)
    gen, regs = dev.registers()
    slot = dev.reserve()
    memory.slot_data[slot][:4] = [1, 2, 3, 4]
    dev.publish(slot, 123_456_789, "odd", gen, regs, SETTINGS.frame_bytes)
    assert host.take(0.0, 123_456_789) is not None

    assert bytes(raw[:8]) == b"RTCTLFG1"
    stride = word(raw, 24)
    assert [word(raw, 8 + 8 * i) for i in range(6)] == [2, 4, stride, MEMORY_BYTES, 0, round(FIELD_PERIOD_S * 1e9)]
    # registers at 128: gen, then density (horizontal), density_v, x, y, width, height, scan,
    # offset, gain, levels, word_bits, shots, trigger
    assert word(raw, 128) == gen and gen % 2 == 0 and gen > 0
    assert [word(raw, 136 + 8 * i) for i in range(13)] == [256, 128, 16, 48, 96, 64, 0, 3, 140, 16, 16, 5, 1]
    assert word(raw, 384) == slot and word(raw, 392) == 1  # writer: published slot, written …
    assert word(raw, 400 + 8 * slot) == 1  # … slot_seq[slot]
    # reader at 640: claim, hold, read, dropped, last_seq
    assert [word(raw, 640 + 8 * i) for i in range(5)] == [-1, slot, 1, 0, 1]
    # slot s at 4096 + s · stride: seq, capture_ns, field, gen, nbytes, the 13 registers; words at 256
    base = 4096 + slot * stride
    assert [word(raw, base + 8 * i) for i in range(5)] == [1, 123_456_789, 1, gen, SETTINGS.frame_bytes]
    assert [word(raw, base + 40 + 8 * i) for i in range(13)] == regs
    assert raw[base + 256:base + 260].tolist() == [1, 2, 3, 4]


def test_the_device_status_is_at_256():
    raw = np.zeros(buffer_bytes(4), dtype=np.uint8)
    memory = GrabberMemory(raw, create=True, n_slots=4)
    dev = DevicePort(memory)
    dev.set_status(2, applied_gen=6, error=7)
    assert [word(raw, 256 + 8 * i) for i in range(3)] == [2, 6, 7]
