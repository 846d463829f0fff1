"""The devices' defect scenarios of issue 25, run in a child process (tests/hardening/in_child.py)
by test_device_defects.py: each returns what the device did, as JSON."""
from __future__ import annotations

from multiprocessing import shared_memory

import numpy as np

from boundary_framegrabber import reclaim
from drivers.framegrabber import ShmFrameGrabber
from drivers.protocols.framegrabber import HEADER_BYTES, W_PUBLISHED, DevicePort, GrabberMemory, buffer_bytes
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.safety.faults import device_reason

GRABBER_SETTINGS = GrabberSettings(density=64, scan="frame")


def framegrabber_garbage() -> dict:
    """The ``framegrabber`` driver attached to a real shared-memory segment whose device end
    publishes frames; then 2^40 as the published slot, then random bytes over the header."""
    shm = shared_memory.SharedMemory(create=True, size=buffer_bytes())
    out = {}
    try:
        memory = GrabberMemory(shm.buf, create=True)
        grabber = ShmFrameGrabber("camera", GRABBER_SETTINGS, shm.name)
        grabber.configure()
        reclaim(shm)
        grabber.activate()  # programs the registers
        device = DevicePort(memory)
        gen, regs = device.registers()

        def publish(capture_ns):
            device.publish(device.reserve(), capture_ns, "frame", gen, regs, GRABBER_SETTINGS.frame_bytes)

        def tick(t, name):
            status = grabber.read(t)
            out[name] = {"status": int(status), "frame": grabber.grab() is not None,
                         "reason": device_reason(grabber, status) if status else None}

        publish(1)
        tick(0.001, "valid")
        memory.writer[W_PUBLISHED] = 2 ** 40
        tick(0.002, "slot 2^40")
        publish(3)  # the device publishes again: the word is a slot once more
        tick(0.003, "published again")
        header = np.ndarray((HEADER_BYTES,), dtype=np.uint8, buffer=shm.buf)
        header[:] = np.random.default_rng(25).integers(0, 256, HEADER_BYTES, dtype=np.uint8)
        tick(0.004, "random header")
        del header, memory, device
        grabber.close()
    finally:
        shm.close()
        shm.unlink()
    return out
