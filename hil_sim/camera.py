"""The camera and the grabber, simulated: PAL timing, digitiser, packing, the shared buffer.

A PAL camera delivers a field every 20 ms, the odd field (TV lines 1, 3, …; the grid's rows
0, 2, …) and the even field alternating; field k starts at k · 20 ms and its picture is
sampled then, with the robot where it is at that instant. The grabber takes the fields its
settings ask for (odd, even, every field, or an odd and the next even field interlaced into
a frame), renders (:mod:`hil_sim.render`), digitises and packs each into a slot it has
reserved in the shared buffer (:mod:`drivers.protocols.framegrabber`), and publishes the
image when its last field ends (a field 20 ms after it was sampled, a frame 40 ms) or, if
later, when the card's transfer of it at its rate ends (:mod:`hil_sim.transfer`; never later
at the paper's 13 MB/s). An image in transfer keeps its slot BUSY.

:meth:`CameraSim.step` advances to a time on the device's clock. In lock-step (the embedded
simulator) it is called every tick with the loop's time, and the work of a field is spread
over the ticks it spans, band by band, as the hardware scans it line by line; free-running
(``hil-sim``) it is called at each field boundary on CLOCK_MONOTONIC and draws a field at once.
A thread wakes late (and waits for the interpreter lock behind the CAN server's): the
free-running camera stamps an image with the moment it actually took the robot's pose.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from drivers.protocols.framegrabber import DONE, FAULT, IDLE, RUNNING, S_FIELDS, S_HEARTBEAT, DevicePort, decode
from rtctl.errors import SettingsError
from rtctl.hal.framegrabber import FIELD_NS, MEMORY_BYTES
from rtctl.vision.pixels import _digitise_pack  # (the image's shapes are checked once, by its settings)
from hil_sim.render import Renderer
from hil_sim.transfer import PAPER_MB_S, TransferChannel

FIRST_FIELD = {"odd": "odd", "even": "even", "fields": None, "frame": "odd"}


class _Image:
    """An image being grabbed: its slot, settings, the fields still to come, and its bands —
    the image rows each tick of a field draws — worked out once."""

    def __init__(self, slot, settings, gen, regs, fields, start_ns, words, analog, bands, plan):
        self.slot, self.settings, self.gen, self.regs = slot, settings, gen, regs
        self.fields, self.index, self.capture_ns = fields, 0, start_ns
        self.start_ns, self.plan = start_ns, plan  # its first field's start; its transfer (TransferChannel.plan)
        self.readable_ns, self.last_shot = 0, False
        s = settings
        rows, width = s.rows, s.width
        self.analog = analog[:rows * width].reshape(rows, width)
        self.flat = self.analog.reshape(-1)
        self.bytes = words.view(np.uint8).reshape(-1)
        self.row_bytes = s.frame_bytes // rows
        self.digitiser = (s.offset / 255.0, s.gain_factor * s.levels, s.levels - 1, s.bits, s.word_bits // 8 - 1)
        per_band = -(-rows // bands)
        self.bands = [(b * per_band, min((b + 1) * per_band, rows)) for b in range(bands)]


class CameraSim:
    def __init__(self, scene, model, memory, q_source, *, ticks_per_field: int = 1, epoch_ns: int = 0, clock=None,
                 transfer_mb_s: float = PAPER_MB_S):
        self.port = DevicePort(memory)
        self.transfer = TransferChannel(transfer_mb_s)
        self._plan = None  # the transfer plan of the settings applied
        self.in_transfer: deque[_Image] = deque()  # scanned, not yet readable (oldest first)
        self.memory = memory
        self.renderer = Renderer(scene, model)
        self.q_source = q_source  # () → the robot's joint positions now
        self.clock = clock  # () → now (ns) when the pose is taken late (free-running); None: on the boundary
        self.spread = ticks_per_field > 1  # lock-step: pose at a field's first tick, draw at the others
        self.bands = max(1, ticks_per_field - 1)
        self.epoch_ns = epoch_ns
        self.field = -1  # index of the field in progress
        self.band = 0
        self.image: _Image | None = None
        self.settings = None
        self.gen = 0  # register generation applied
        self.regs: list[int] = []
        self.trigger = None
        self.shots_done = 0
        self.state = IDLE
        self.missed_fields = 0  # field boundaries the caller stepped over (free-running under load)
        self.settings_errors = 0
        self._analog = np.zeros(MEMORY_BYTES, dtype=np.float32)  # the video signal of the largest image

    # -- time ------------------------------------------------------------------------------
    def step(self, t_ns: int) -> None:
        """Advance to ``t_ns`` on the device's clock: finish and publish what is complete, start
        the field in progress, draw its next band."""
        k = (t_ns - self.epoch_ns) // FIELD_NS
        new_field = k > self.field
        if new_field:
            self._finish_field()
        while self.in_transfer and self.in_transfer[0].readable_ns <= t_ns:
            self._publish(self.in_transfer.popleft())
        if new_field:
            if k > self.field + 1 and self.field >= 0:
                self.missed_fields += k - self.field - 1
                self._abandon()  # an interlaced frame cannot take a field that is not the next
            self.field = k
            self._start_field(k)
            if self.spread:
                return
        if self.image is not None and self.band < self.bands:
            self._draw_band(self.band)
            self.band += 1

    def _finish_field(self) -> None:
        image = self.image
        if image is None:
            return
        while self.band < self.bands:
            self._draw_band(self.band)
            self.band += 1
        image.index += 1
        if image.index == len(image.fields):
            image.readable_ns = self.transfer.readable_ns(image.start_ns, image.plan)
            self.in_transfer.append(image)
            self.image = None
            self.shots_done += 1
            if image.settings.shots and self.shots_done >= image.settings.shots:
                self.state = DONE  # no new image; the status says so once this one is readable
                image.last_shot = True

    def _publish(self, image: _Image) -> None:
        field = image.fields[0] if len(image.fields) == 1 else "frame"
        self.port.publish(image.slot, image.capture_ns, field, image.gen, image.regs, image.settings.frame_bytes)
        if image.last_shot and self.state == DONE:
            self.port.set_status(DONE)

    def next_event_ns(self) -> int:
        """When :meth:`step` has work next: the next field boundary, or an image's hand-over."""
        boundary = self.epoch_ns + (self.field + 1) * FIELD_NS
        return min(boundary, self.in_transfer[0].readable_ns) if self.in_transfer else boundary

    def _abandon(self) -> None:
        if self.image is not None:
            self.port.abandon(self.image.slot)
            self.image = None

    # -- a field ---------------------------------------------------------------------------
    def _start_field(self, k: int) -> None:
        parity = "odd" if k % 2 == 0 else "even"
        status = self.memory.status
        status[S_FIELDS], status[S_HEARTBEAT] = k, self.epoch_ns + k * FIELD_NS
        self.band = 0
        if self.image is None:
            self._apply_registers()
            s = self.settings
            if self.state != RUNNING or FIRST_FIELD[s.scan] not in (None, parity):
                return
            slot = self.port.reserve()
            if slot < 0:
                return
            fields = ("odd", "even") if s.scan == "frame" else (parity,)
            self.image = _Image(slot, s, self.gen, self.regs, fields, self.epoch_ns + k * FIELD_NS,
                                self.memory.words(slot, s), self._analog, self.bands, self._plan)
        q = self.q_source()
        if self.image.index == 0:  # the image's capture time: when its (first) field's pose was taken
            self.image.capture_ns = self.epoch_ns + k * FIELD_NS if self.clock is None else self.clock()
        self.renderer.freeze(q, self.image.settings.density_h, k)

    def _apply_registers(self) -> None:
        got = self.port.registers()
        if got is None or got[0] == self.gen:
            return
        gen, regs = got
        try:
            settings = decode(regs)
        except SettingsError:
            self.settings_errors += 1
            self.gen = gen
            self.port.set_status(FAULT, applied_gen=self.gen, error=self.settings_errors)
            return
        trigger = regs[-1]
        if trigger != self.trigger:  # a new program (or an N-shot trigger): start counting again
            self.trigger, self.shots_done, self.state = trigger, 0, RUNNING
        self.settings, self.gen, self.regs = settings, gen, regs
        self._plan = self.transfer.plan(settings)
        self.port.set_status(self.state, applied_gen=gen)

    def _draw_band(self, b: int) -> None:
        """Image rows of band b: draw this field's share; digitise and pack them when the
        image's last field has drawn them."""
        image = self.image
        begin, end = image.bands[b]
        if begin >= end:
            return
        s = image.settings
        x, y = s.window[0], s.window[1]
        field = image.fields[image.index]
        if len(image.fields) == 1:  # a field: image row i is grid row y + 2i (+1 for the even field)
            band, row0, row_step = range(begin, end), y + (field == "even"), 2
        else:  # a frame: image row i is grid row y + i; this field draws the rows of its parity
            first = begin + ((y + begin) % 2 != (field == "even"))
            band, row0, row_step = range(first, end, 2), y, 1
        self.renderer.draw(image.analog, band, row0, row_step, x, s.density_h, s.density_v)
        if image.index == len(image.fields) - 1:
            width, row_bytes = s.width, image.row_bytes
            _digitise_pack(image.flat[begin * width:end * width], *image.digitiser,
                           image.bytes[begin * row_bytes:end * row_bytes])
