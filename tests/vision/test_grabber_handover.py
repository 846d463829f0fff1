"""The framegrabber wire's two hand-overs that a torn or stale read would break
(drivers/protocols/framegrabber.py, the layout's docstring): the registers are a sequence
lock — the device takes a register set only when the generation is even (non-zero) and the
same before and after its read; and a host that attaches counts from what was already
written — a frame completed before it looked is neither new nor dropped (dropped = written −
read, both since it attached)."""
import numpy as np

from drivers.protocols.framegrabber import (CLOCK_LOOP, H_DROPPED, H_LAST, H_READ, R_GEN, DevicePort, GrabberMemory,
                                            buffer_bytes, encode)
from drivers.protocols.framegrabber_host import HostPort
from rtctl.hal.framegrabber import GrabberSettings

OLD = GrabberSettings(density=128, scan="frame", levels=256, word_bits=32)
NEW = GrabberSettings(density=256, scan="odd", levels=16, word_bits=8)


def test_a_register_set_being_written_is_not_taken():
    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
    host, dev = HostPort(memory), DevicePort(memory)
    assert dev.registers() is None  # generation 0: never written
    host.program(OLD)
    gen, words = dev.registers()
    assert gen % 2 == 0 and words == encode(OLD, 1)
    # the host in the middle of its next write (as program() does it): generation odd, half the words new
    regs = memory.regs
    regs[R_GEN] = gen + 1
    regs[1:7] = encode(NEW, 2)[:6]
    assert dev.registers() is None
    regs[7:] = encode(NEW, 2)[6:]
    assert dev.registers() is None  # all written, the generation not yet released
    regs[R_GEN] = gen + 2
    assert dev.registers() == (gen + 2, encode(NEW, 2))


def _publish(dev):
    """One frame with the registers in force, captured at the device's sequence number in ms."""
    gen, words = dev.registers()
    slot = dev.reserve()
    return dev.publish(slot, 1_000_000 * dev.seq, "frame", gen, words, OLD.frame_bytes)


def test_frames_written_before_the_host_attached_are_neither_taken_nor_dropped():
    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
    HostPort(memory).program(OLD)  # an earlier host (an earlier run, a restarted rtctl) …
    dev = DevicePort(memory)
    for _ in range(3):  # … whose device went on writing
        _publish(dev)
    host = HostPort(memory)
    assert host.take(1.0, 0) is None  # nothing new since attaching
    assert (host.read, host.dropped, host.written) == (0, 0, 0)
    # the reader section publishes the same (layout: read, dropped, last_seq — the last frame accounted for)
    assert memory.reader[[H_READ, H_DROPPED, H_LAST]].tolist() == [0, 0, 3]
    seq = _publish(dev)
    frame = host.take(1.0, 0)
    assert frame is not None and frame.seq == seq == 4
    assert (host.read, host.dropped, host.written) == (1, 0, 1)
    _publish(dev)
    _publish(dev)
    assert host.take(1.0, 0).seq == 6
    assert host.dropped == host.written - host.read == 1
