"""The framegrabber's host end: the newest frame held, checked and described; the base of the
drivers that read a grabber through the shared buffer (:mod:`drivers.protocols.framegrabber`).

**Nothing read from the segment is trusted** (another process, or a bug, may write anything
there): the layout is checked when the host attaches and again at every poll (a changed
layout is a restarted or corrupt device); the published slot index must be a slot; a slot's
sequence number must advance (BUSY or 0: nothing new), by at most :data:`MAX_SKIP`; the
device's state must be one of its four; a frame's header must repeat its sequence number,
name a register generation this host programmed (or one from before it attached), a field
its scan delivers, exactly the bytes its settings make, and a capture time not after now nor
before the previous frame's. Anything else raises :class:`~rtctl.errors.ProtocolError`
naming the word and its value: the device's ERROR in that tick, never a wild read. The host
keeps its own bookkeeping (last sequence number, read, dropped) in its private memory and
only publishes a copy of it.
"""
from __future__ import annotations

import time

import numpy as np

from drivers.protocols.framegrabber import (
    BAD_LAYOUT, BAD_SEQ, BAD_SLOT, BAD_STATE, CAPTURE_SLACK_NS, CLOCK_LOOP, DEVICE_FAULT, F_CAPTURE, F_FIELD, F_GEN,
    F_NBYTES, F_REGS, F_SEQ, FAULT, FIELD_NAMES, H_CLAIM, H_DROPPED, H_HOLD, H_LAST, H_READ, IDLE, MAX_COUNT, MAX_SKIP,
    NOTHING, O_BAD, O_CAPTURE, O_DROPPED, O_LAST, O_READ, O_SEQ, R_GEN, RACE, S_APPLIED, S_ERROR, S_FIELDS, S_STATE,
    SCAN_FIELDS, SEQ_BACK, SEQ_JUMP, STATE_NAMES, W_WRITTEN, DevicePort, GrabberMemory, buffer_bytes, decode, encode,
    host_claim, host_commit, store_fenced)
from rtctl.errors import ProtocolError, SettingsError
from rtctl.hal.framegrabber import Frame, FrameGrabber, GrabberSettings, LoopClock
from rtctl.vision.pixels import unpack

CLAIM_ATTEMPTS = 3  # claims in one tick while the device reuses the slot under them; then nothing until the next


class HostPort:
    """The host's end: program the registers, hold the newest frame, check and describe it."""

    def __init__(self, memory: GrabberMemory):
        self.m = memory
        self._trigger = 0
        self._gen = _count(memory.regs[R_GEN], "register generation")  # the host's own copy from here on
        self._settings: dict[int, GrabberSettings] = {}  # register generation → settings (few)
        self._frames: list[Frame | None] = [None] * memory.n_slots  # one per slot, reused
        self._gens = [-1] * memory.n_slots  # the generation each slot's frame view was made for
        self.clock = LoopClock()
        self.start = _count(memory.writer[W_WRITTEN], "frames written")  # frames before we looked are not dropped
        self.expected = memory.ident.copy()  # the layout as attached
        self.own = np.zeros(O_BAD + 1, dtype=np.int64)  # private: O_LAST, O_READ, O_DROPPED …
        self.own[O_LAST] = self.start
        r = memory.reader
        r[[H_CLAIM, H_HOLD]] = -1
        r[[H_READ, H_DROPPED]] = 0
        r[H_LAST] = self.start

    def program(self, settings: GrabberSettings) -> None:
        """Write the registers under their sequence lock; starts a burst in N-shot mode."""
        regs, self._trigger = self.m.regs, self._trigger + 1
        gen = self._gen + 1 | 1
        store_fenced(regs, R_GEN, gen)  # odd: being written
        regs[1:] = encode(settings, self._trigger)
        store_fenced(regs, R_GEN, gen + 1)
        self._gen = gen + 1
        self._remember(self._gen, settings)

    def claim(self) -> int:
        """Slot of a new newest frame now held, or NOTHING (never waits); ProtocolError when a
        word of the segment is invalid."""
        m = self.m
        for _ in range(CLAIM_ATTEMPTS):  # RACE: the device reused the slot while we looked; its newer frame is there
            slot = host_claim(m.ident, self.expected, m.status, m.writer, m.reader, self.own, m.n_slots)
            if slot >= 0 or slot == NOTHING:
                return slot
            if slot != RACE:
                raise ProtocolError(self._describe(slot))
        return NOTHING

    def take(self, t: float, now_ns: int) -> Frame | None:
        """The newest frame if it is new, now held (its words a zero-copy view), else None.
        Its capture time is put on the loop's clock: the device's own (lock-step), or its
        CLOCK_MONOTONIC stamp through :class:`~rtctl.hal.framegrabber.LoopClock` (``now_ns``:
        CLOCK_MONOTONIC at this read of tick time ``t``). ProtocolError for an invalid word."""
        slot = self.claim()
        if slot < 0:
            return None
        h = self.m.slot_headers[slot]
        seq, gen, field = int(h[F_SEQ]), int(h[F_GEN]), int(h[F_FIELD])
        if seq != self.own[O_SEQ]:
            raise ProtocolError(f"slot {slot}: header sequence number {seq}, the device published {self.own[O_SEQ]}")
        settings = self._settings_of(gen, h)
        if field not in SCAN_FIELDS[settings.scan]:  # (every code a scan delivers is a field's)
            raise ProtocolError(f"slot {slot}: field code {field}, scan {settings.scan!r} delivers "
                                f"{[FIELD_NAMES[f] for f in SCAN_FIELDS[settings.scan]]}")
        if int(h[F_NBYTES]) != settings.frame_bytes:
            raise ProtocolError(f"slot {slot}: {int(h[F_NBYTES])} bytes, its settings make {settings.frame_bytes}")
        capture_ns = int(h[F_CAPTURE])
        loop = self.m.clock == CLOCK_LOOP
        # the clock read now, not only the caller's: a host preempted between its read and this
        # claim sees frames stamped after it (a slow reader failed a valid stream under load)
        now = round(t * 1e9) if loop else max(now_ns, time.monotonic_ns()) + CAPTURE_SLACK_NS
        if not self.own[O_CAPTURE] <= capture_ns <= now:
            raise ProtocolError(f"slot {slot}: capture time {capture_ns} ns before the previous frame's "
                                f"({self.own[O_CAPTURE]}) or after now ({now})")
        host_commit(self.own, self.m.reader, capture_ns)
        capture = capture_ns * 1e-9 if loop else self.clock.to_loop(t, now_ns, capture_ns)
        frame = self._frames[slot]
        if frame is None or self._gens[slot] != gen:
            frame = self._frames[slot] = Frame(0, 0.0, "frame", settings, self.m.words(slot, settings), unpack)
            self._gens[slot] = gen
        frame.seq, frame.capture_time, frame.field = seq, capture, FIELD_NAMES[field]
        return frame

    def _settings_of(self, gen: int, header) -> GrabberSettings:
        """The settings of register generation ``gen``: programmed by this host, or (from before
        it attached) the frame's own registers, checked as any settings are."""
        settings = self._settings.get(gen)
        if settings is not None:
            return settings
        if gen <= 0 or gen & 1 or gen > self._gen:
            raise ProtocolError(f"register generation {gen} was never programmed (the last is {self._gen})")
        try:
            settings = decode(header[F_REGS:])
        except (SettingsError, ValueError) as e:
            raise ProtocolError(f"register generation {gen}: the frame's registers are no settings ({e})") from None
        self._remember(gen, settings)
        return settings

    def _remember(self, gen: int, settings: GrabberSettings) -> None:
        if len(self._settings) >= 16:  # bounded, whatever generations a device sends
            self._settings.clear()
        self._settings[gen] = settings

    def _describe(self, code: int) -> str:
        bad, last = int(self.own[O_BAD]), int(self.own[O_LAST])
        if code == BAD_LAYOUT:
            return (f"layout word {bad} changed from {int(self.expected[bad])} to {int(self.m.ident[bad])} "
                    f"(the device restarted, or the segment was overwritten)")
        return {BAD_STATE: f"device state {bad}, expected {IDLE}..{FAULT}",
                DEVICE_FAULT: f"the device reports FAULT ({bad} settings refused)",
                BAD_SLOT: f"published slot index {bad}, expected -1..{self.m.n_slots - 1}",
                BAD_SEQ: f"slot sequence number {bad}",
                SEQ_BACK: f"sequence number ran backwards: {bad} after {last}",
                SEQ_JUMP: f"sequence number jumped from {last} to {bad} (more than {MAX_SKIP} frames)"}[code]

    def release(self) -> None:
        self.m.reader[H_HOLD] = -1

    @property
    def read(self) -> int:
        """Frames taken since this end attached."""
        return int(self.own[O_READ])

    @property
    def dropped(self) -> int:
        """Frames the device completed since this end attached that it never took."""
        return int(self.own[O_DROPPED])

    @property
    def written(self) -> int:
        return int(self.m.writer[W_WRITTEN]) - self.start

    def device_status(self) -> dict:
        s = self.m.status
        state = int(s[S_STATE])
        return {"state": STATE_NAMES[state] if IDLE <= state <= FAULT else f"<state {state}>",
                "applied_gen": int(s[S_APPLIED]), "settings_errors": int(s[S_ERROR]), "fields": int(s[S_FIELDS]),
                "written": self.written}


def _count(word, what: str) -> int:
    value = int(word)
    if not 0 <= value < MAX_COUNT:
        raise ProtocolError(f"framegrabber {what} {value}, expected 0 ≤ it < 2^62")
    return value


class HostFrameGrabber(FrameGrabber):
    """A framegrabber device read through this protocol: subclasses open ``self.host`` (a
    :class:`HostPort`) when configured."""

    host: HostPort | None = None

    def _poll(self, t: float) -> bool:
        frame = self.host.take(t, time.monotonic_ns())
        if frame is None:
            return False
        self._latest = frame
        self.frames, self.dropped = self.host.read, self.host.dropped
        return True

    def _send(self, settings: GrabberSettings, t: float) -> None:
        self.host.program(settings)


def warm_up() -> None:
    """Load the compiled arbitration kernels before the loop starts."""
    m = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True)
    dev, host, settings = DevicePort(m), HostPort(m), GrabberSettings()
    host.program(settings)
    gen, words = dev.registers()
    slot = dev.reserve()
    dev.publish(slot, 0, "odd", gen, words, settings.frame_bytes)
    host.take(0.0, 0)
