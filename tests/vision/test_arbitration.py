"""The shared frame buffer's arbitration: a frame is never read while it is written, a slow
reader drops frames and counts them exactly, neither side waits.

Every frame carries its own sequence number in each of its 8-byte words, so a frame torn
between two writes cannot pass the check; the reader checks each frame when it takes it and
again after holding it a while (the device must not write a held slot).
"""
import multiprocessing
import random
import time

import numpy as np
import pytest

from drivers.framegrabber import attach_shared_memory
from drivers.protocols.framegrabber import BUSY, H_CLAIM, H_HOLD, W_SEQ0, DevicePort, GrabberMemory, buffer_bytes
from drivers.protocols.framegrabber_host import HostPort
from rtctl.hal.framegrabber import GrabberSettings
from vision_rig import programmed_pair

SETTINGS = GrabberSettings(density=128, scan="frame", levels=256, word_bits=32)
ENOUGH = {"read": 200, "held": 20}  # the reader's checks before it lets the device stop
GIVE_UP_S = 120.0  # (a loaded machine may starve either side for a while: volume, not speed, is the test)


def _writer(name: str, stop, result) -> None:
    """The device at full rate until ``stop``: reserve, write row by row (slowly enough to be
    caught), publish."""
    shm = attach_shared_memory(name)
    memory = GrabberMemory(shm.buf)
    dev = DevicePort(memory)
    while (regs := dev.registers()) is None:
        time.sleep(1e-3)
    gen, words = regs
    rows = SETTINGS.rows
    while not stop.is_set():
        slot = dev.reserve()
        if slot < 0:
            continue
        pattern = memory.slot_data[slot][:SETTINGS.frame_bytes].view(np.int64).reshape(rows, -1)
        for r in range(rows):
            pattern[r] = dev.seq + 1
        dev.publish(slot, time.monotonic_ns(), "frame", gen, words, SETTINGS.frame_bytes)
    result.put((dev.seq, dev.skipped))
    del pattern, memory, dev
    shm.close()


def test_slow_reader_across_processes_never_sees_a_torn_frame():
    from multiprocessing import shared_memory

    shm = shared_memory.SharedMemory(create=True, size=buffer_bytes())
    try:
        memory = GrabberMemory(shm.buf, create=True)
        host = HostPort(memory)
        host.program(SETTINGS)
        ctx = multiprocessing.get_context("spawn")
        result, stop = ctx.Queue(), ctx.Event()
        writer = ctx.Process(target=_writer, args=(shm.name, stop, result))
        writer.start()
        rng = random.Random(7)
        read, seqs, held_checks = 0, [], 0
        give_up = time.monotonic() + GIVE_UP_S
        while True:
            if (read >= ENOUGH["read"] and held_checks >= ENOUGH["held"] and host.dropped > 0
                    or time.monotonic() > give_up):
                stop.set()  # then the last frames: the reader must see the very last one
            done = not writer.is_alive()
            frame = host.take(0.0, time.monotonic_ns())
            if frame is not None:
                data = frame.words.view(np.int64)
                assert np.all(data == frame.seq), f"torn frame {frame.seq}: {np.unique(data)}"
                read += 1
                seqs.append(frame.seq)
                if rng.random() < 0.3:  # hold it while the device goes on, then look again
                    time.sleep(rng.uniform(0, 0.002))
                    assert np.all(data == frame.seq), f"frame {frame.seq} written while held"
                    held_checks += 1
            elif done:
                break
            time.sleep(rng.uniform(0, 0.0003))  # deliberately slower than the device
        written, skipped = result.get(timeout=10)
        writer.join(10)
        assert seqs == sorted(set(seqs)) and seqs[-1] == written  # in order, no repeats, the last one seen
        assert host.read == read and host.dropped == written - read  # exactly
        assert host.dropped > 0 and read >= ENOUGH["read"] and held_checks >= ENOUGH["held"], (read, held_checks)
        assert skipped == 0  # with four slots the device always had a free one
        del frame, data, host, memory
    finally:
        shm.close()
        shm.unlink()


def test_device_never_reserves_the_published_held_or_claimed_slot():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    slot = dev.reserve()
    dev.publish(slot, 0, "frame", gen, regs, SETTINGS.frame_bytes)
    held = host.claim()
    assert held == slot and memory.reader[H_HOLD] == slot
    newer = dev.reserve()
    dev.publish(newer, 0, "frame", gen, regs, SETTINGS.frame_bytes)
    memory.reader[H_CLAIM] = 3 if 3 not in (held, newer) else 2  # a claim in flight
    claimed = int(memory.reader[H_CLAIM])
    for _ in range(20):
        s = dev.reserve()
        assert s not in (held, newer, claimed)
        memory.writer[W_SEQ0 + s] = 0  # give it back unpublished
    memory.reader[H_CLAIM] = -1


def test_claim_fails_cleanly_when_the_slot_is_being_written():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    slot = dev.reserve()
    dev.publish(slot, 0, "frame", gen, regs, SETTINGS.frame_bytes)
    memory.writer[W_SEQ0 + slot] = BUSY  # the device took the slot back between our two looks
    assert host.claim() == -1 and memory.reader[H_CLAIM] == -1 and host.read == 0


def test_nothing_new_is_none_and_the_held_frame_stays():
    memory, host, dev, gen, regs = programmed_pair(SETTINGS)
    assert host.take(0.0, 0) is None
    slot = dev.reserve()
    dev.publish(slot, 123, "frame", gen, regs, SETTINGS.frame_bytes)
    frame = host.take(1.0, 2_000_000_000)
    assert (frame.seq, frame.field, frame.settings) == (1, "frame", SETTINGS)
    # CLOCK_MONOTONIC: loop time 1 s was monotonic 2 s at this read, so 123 ns is loop −1 s + 123 ns
    assert frame.capture_time == pytest.approx(-1.0 + 123e-9)
    assert host.take(1.0, 0) is None and memory.reader[H_HOLD] == slot


def test_loop_clock_takes_the_earliest_read():
    from rtctl.hal.framegrabber import LoopClock

    clock = LoopClock()
    # loop time t read at monotonic now: 5 ms late, then on time, then 2 ms late
    assert clock.to_loop(1.000, 10_005_000_000, 9_990_000_000) == pytest.approx(0.985)
    assert clock.to_loop(1.001, 10_001_000_000, 9_990_000_000) == pytest.approx(0.990)
    assert clock.to_loop(1.002, 10_004_000_000, 9_990_000_000) == pytest.approx(0.990)  # a late read moves nothing
