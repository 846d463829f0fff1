"""The framegrabber's input boundary (boundary_fuzz.py): the words of its shared segment."""
from __future__ import annotations

import contextlib
import time
from multiprocessing import resource_tracker, shared_memory

import numpy as np
from hypothesis import strategies as st

from boundary_fuzz import DeviceBoundary, Expect
from drivers.protocols import framegrabber as fg
from rtctl.hal.framegrabber import GrabberSettings

INT64 = st.integers(-2 ** 63, 2 ** 63 - 1)


def reclaim(shm: shared_memory.SharedMemory) -> None:
    """Call after a driver in this process attached to ``shm``, which this process created: the
    attach gave up the resource tracker's claim on it (drivers.framegrabber.attach_shared_memory),
    so it is made again — else the unlink at the end is a KeyError in the tracker's process."""
    resource_tracker.register(shm._name, "shared_memory")  # noqa: SLF001


class FramegrabberWords(DeviceBoundary):
    """The ``framegrabber`` driver attached to a real shared-memory segment: its device end
    publishes valid frames among writes of any value into any word of the layout, registers,
    status, writer and reader sections and slot headers, sequence numbers near the last, and
    random bytes over the header. The host checks the layout, the device's state and the
    published slot index at every poll, before anything else: while any of them is invalid,
    every tick is the camera's ERROR."""

    SETTINGS = GrabberSettings(density=64, scan="fields")
    EXAMPLES = [  # issue 25, defect 1: 2^40 as the published slot; random bytes over the header
        [("publish",), ("word", "writer", fg.W_PUBLISHED, 2 ** 40), ("publish",)],
        [("publish",), ("bytes", 0, np.random.default_rng(25).bytes(64))],
        [("publish",), ("publish",), ("seq", 0), ("seq", -1), ("publish",)],
    ]

    def steps(self):
        special = st.sampled_from([-2 ** 63, -2, -1, 0, 1, 2, 3, 4, 15, 16, 2 ** 31, 2 ** 40, 2 ** 62, 2 ** 63 - 1])
        word = special | INT64
        sections = st.sampled_from(["layout", "regs", "status", "writer", "reader"])
        return st.lists(st.one_of(
            st.just(("publish",)),
            st.tuples(st.just("word"), sections, st.integers(0, 17), word),
            st.tuples(st.just("slot"), st.integers(0, 3), st.integers(0, fg.F_REGS + len(fg.REG_NAMES) - 1), word),
            st.tuples(st.just("seq"), st.integers(-3, 3) | st.sampled_from([fg.MAX_SKIP, fg.MAX_SKIP + 1])),
            st.tuples(st.just("bytes"), st.integers(0, fg.HEADER_BYTES - 1), st.binary(min_size=1, max_size=64)),
        ), min_size=1, max_size=12)

    @contextlib.contextmanager
    def open(self):
        from drivers.framegrabber import ShmFrameGrabber

        shm = shared_memory.SharedMemory(create=True, size=fg.buffer_bytes())
        grabber = None
        try:
            self.memory = fg.GrabberMemory(shm.buf, create=True)
            grabber = ShmFrameGrabber("camera", self.SETTINGS, shm.name)
            grabber.configure()
            reclaim(shm)
            grabber.activate()
            self.ident = self.memory.ident.copy()  # the layout as the host attached to it
            self.device = fg.DevicePort(self.memory)
            self.regs = self.device.registers()
            self._publish()
            yield grabber
        finally:
            self.memory = self.device = None
            if grabber is not None:
                grabber.close()
            shm.close()
            shm.unlink()

    def _publish(self):
        slot = self.device.reserve()
        if slot >= 0:  # (garbage in the host's words can leave the device no free slot)
            field = "odd" if self.device.seq % 2 == 0 else "even"
            self.device.publish(slot, time.monotonic_ns(), field, *self.regs, self.SETTINGS.frame_bytes)

    def inject(self, dev, step) -> Expect:
        m = self.memory
        kind = step[0]
        if kind == "publish":
            self._publish()
        elif kind == "word":
            _, section, index, value = step
            words = getattr(m, section)
            words[index % words.size] = value
        elif kind == "slot":
            _, slot, index, value = step
            m.slot_headers[slot][index] = value
        elif kind == "seq":  # the published slot's sequence number (writer and header) moved
            p = int(m.writer[fg.W_PUBLISHED])
            if 0 <= p < m.n_slots:
                seq = int(m.writer[fg.W_SEQ0 + p]) + step[1]
                m.writer[fg.W_SEQ0 + p] = m.slot_headers[p][fg.F_SEQ] = seq
        else:
            _, offset, data = step
            data = data[:fg.HEADER_BYTES - offset]
            np.ndarray((len(data),), dtype=np.uint8, buffer=m.buffer, offset=offset)[:] = np.frombuffer(data, np.uint8)
        return self._expect()

    def _expect(self) -> Expect:
        """The words the host must refuse before it looks at anything else, as this test wrote them."""
        m = self.memory
        changed = np.flatnonzero(m.ident != self.ident)
        if changed.size:
            return Expect(error=True, why=f"layout word {changed[0]} changed")
        state = int(m.status[fg.S_STATE])
        if state not in (fg.IDLE, fg.RUNNING, fg.DONE):
            return Expect(error=True, why=f"device state {state}")
        published = int(m.writer[fg.W_PUBLISHED])
        if not -1 <= published < m.n_slots:
            return Expect(error=True, why=f"published slot index {published}")
        return Expect()

    def tick(self, dev, k):
        t = 0.001 * k
        status = dev.read(t)
        return max(status, dev.write(t))
