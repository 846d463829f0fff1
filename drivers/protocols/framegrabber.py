"""The framegrabber's wire, written once for both ends: registers and the shared frame buffer.

The paper's interface keeps images in on-board RAM that the host can map as memory, and
arbitrates so that host and grabber never use the same memory at once. Here that memory is
one buffer (``multiprocessing.shared_memory`` across processes, a plain array in-process)
laid out as (all integers little-endian int64)::

    0      magic "RTCTLFG1", then LAYOUT: version, n_slots, slot_stride, data_bytes, clock, field_ns
           (clock: 0 = capture times on CLOCK_MONOTONIC, 1 = on the loop's clock, lock-step)
    128    REGISTERS (host → device): gen, density (horizontal), density_v, x, y, width, height, scan,
           offset, gain, levels, word_bits, shots, trigger      — a sequence lock: gen odd while written
           (scan: 0 odd, 1 even, 2 fields, 3 frame)
    256    STATUS (device → host): state, applied_gen, error, fields, heartbeat_ns
    384    WRITER (device only): published slot, written, slot_seq[n_slots]
           (slot_seq: −1 while the device writes the slot, 0 never written or given back)
    640    READER (host only):  claim, hold, read, dropped, last_seq
    4096   slot s at 4096 + s · slot_stride: header (seq, capture_ns, field, gen, nbytes,
           then the 13 registers the frame was taken with), packed words from byte 256
           (field: 0 a frame, 1 odd, 2 even)

**Arbitration** (ownership handed over, never shared): the device writes a frame into a slot
it has *reserved*, and publishes it when complete; the host *holds* the slot of the frame it
is using. Each side writes only its own words. To reserve slot s the device marks it busy,
then (after a full memory fence) checks that the host neither holds nor claims it; to take
the newest frame the host claims its slot, then (after a fence) checks the slot still holds
that frame. Whichever of the two comes second sees the other (Dekker's argument), so a frame
is never read while it is written, and neither side ever waits: with ≥ 4 slots there is
always a free one beside the published, the held and the claimed. A host slower than the
device takes the newest frame and counts the ones it skipped: ``dropped = written − read``.


The host's end, which checks every word it reads, is :mod:`drivers.protocols.framegrabber_host`.
"""
from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from rtctl.errors import ProtocolError
from rtctl.hal.framegrabber import FIELD_NS, MEMORY_BYTES, SCANS, GrabberSettings

MAGIC = b"RTCTLFG1"
VERSION = 2  # 2: the vertical density register (the 16 modes)
HEADER_BYTES = 4096
SLOT_HEADER_BYTES = 256
MIN_SLOTS, MAX_SLOTS = 4, 16
CLOCK_MONOTONIC, CLOCK_LOOP = 0, 1  # capture_ns: CLOCK_MONOTONIC, or the loop's time (lock-step)
IDLE, RUNNING, DONE, FAULT = 0, 1, 2, 3  # device state
FIELD_NAMES = ("frame", "odd", "even")
FIELD_CODES = {name: code for code, name in enumerate(FIELD_NAMES)}
BUSY = -1  # slot_seq while the device writes the slot; 0 = never written
STATE_NAMES = ("idle", "running", "done", "fault")
SCAN_FIELDS = {"odd": (1,), "even": (2,), "fields": (1, 2), "frame": (0,)}  # the field codes each scan delivers
MAX_SKIP = 1 << 20  # frames a device can complete between two polls: far more than any camera does
MAX_COUNT = 1 << 62  # sequence numbers and generations stay below it (no int64 overflow)
CAPTURE_SLACK_NS = 1_000_000  # a CLOCK_MONOTONIC stamp may lead the host's "now", read before the claim

# word indices within each section
L_VERSION, L_SLOTS, L_STRIDE, L_DATA, L_CLOCK, L_FIELD_NS = range(6)
REG_NAMES = ("density", "density_v", "x", "y", "width", "height", "scan", "offset", "gain", "levels", "word_bits", "shots", "trigger")
R_GEN = 0
S_STATE, S_APPLIED, S_ERROR, S_FIELDS, S_HEARTBEAT = range(5)
W_PUBLISHED, W_WRITTEN, W_SEQ0 = 0, 1, 2
H_CLAIM, H_HOLD, H_READ, H_DROPPED, H_LAST = range(5)
F_SEQ, F_CAPTURE, F_FIELD, F_GEN, F_NBYTES, F_REGS = range(6)
O_LAST, O_READ, O_DROPPED, O_SEQ, O_CAPTURE, O_BAD = range(6)  # the host's private bookkeeping
IDENT_WORDS = 7  # the magic and L_VERSION … L_FIELD_NS: what the host checks at every poll
# what _claim returns besides a slot
NOTHING, RACE, BAD_LAYOUT, BAD_SLOT, BAD_SEQ, SEQ_BACK, SEQ_JUMP, BAD_STATE, DEVICE_FAULT = range(-1, -10, -1)
_OFFSETS = {"layout": 8, "regs": 128, "status": 256, "writer": 384, "reader": 640}
_WORDS = {"layout": 15, "regs": 1 + len(REG_NAMES), "status": 16, "writer": 2 + MAX_SLOTS, "reader": 8}


def buffer_bytes(n_slots: int = MIN_SLOTS) -> int:
    return HEADER_BYTES + n_slots * (SLOT_HEADER_BYTES + MEMORY_BYTES)


@intrinsic
def _fence(typingctx):
    """A full (sequentially consistent) memory fence: orders a store before a later load."""
    def codegen(context, builder, signature, args):
        builder.fence("seq_cst")
        return context.get_dummy_value()
    return types.void(), codegen


@njit(cache=True)
def _reserve(writer, reader, n_slots, start):
    """Device: a slot to write (marked BUSY) that is neither published, held nor claimed, nor
    BUSY already (an image still in transfer); −1 if none. The search goes up from ``start``
    round the ring (the device passes the slot after its last one: it writes the slots in turn)."""
    published = writer[W_PUBLISHED]
    for k in range(2 * n_slots):
        s = (start + k) % n_slots
        old = writer[W_SEQ0 + s]
        if s == published or old == BUSY:
            continue
        writer[W_SEQ0 + s] = BUSY
        _fence()
        if reader[H_CLAIM] != s and reader[H_HOLD] != s:
            return s
        writer[W_SEQ0 + s] = old  # the host has it: leave it as it was
    return -1


@njit(cache=True)
def _publish(writer, slot, seq):
    _fence()  # the frame's bytes before its sequence number
    writer[W_SEQ0 + slot] = seq
    writer[W_PUBLISHED] = slot
    writer[W_WRITTEN] = seq


@njit(cache=True)
def host_claim(ident, expected, status, writer, reader, own, n_slots):
    """Host: hold the newest complete frame if it is newer than the last one → slot, else
    NOTHING, RACE (lost a race with the device: try again) or an error code (``own[O_BAD]``:
    the offending value). Every word is checked before it is used as an index or a count."""
    for i in range(IDENT_WORDS):
        if ident[i] != expected[i]:
            own[O_BAD] = i
            return BAD_LAYOUT
    state = status[S_STATE]
    if state < IDLE or state > FAULT:
        own[O_BAD] = state
        return BAD_STATE
    if state == FAULT:
        own[O_BAD] = status[S_ERROR]
        return DEVICE_FAULT
    p = writer[W_PUBLISHED]
    if p == -1:
        return NOTHING
    if p < 0 or p >= n_slots:
        own[O_BAD] = p
        return BAD_SLOT
    seq = writer[W_SEQ0 + p]
    last = own[O_LAST]
    if seq == BUSY or seq == 0 or seq == last:  # being rewritten, abandoned, or the frame we have
        return NOTHING
    own[O_BAD] = seq
    if seq < BUSY:
        return BAD_SEQ
    if seq < last:
        return SEQ_BACK
    if seq - last > MAX_SKIP:
        return SEQ_JUMP
    reader[H_CLAIM] = p
    _fence()
    if writer[W_SEQ0 + p] != seq:
        reader[H_CLAIM] = -1
        return RACE
    reader[H_HOLD] = p  # the previously held slot goes back to the device
    reader[H_CLAIM] = -1
    own[O_SEQ] = seq
    return p


@njit(cache=True)
def host_commit(own, reader, capture_ns):
    """Host: the held frame (sequence number ``own[O_SEQ]``) passed its checks: count it, and
    publish the host's bookkeeping (a copy: the host never reads it back)."""
    seq = own[O_SEQ]
    own[O_DROPPED] += seq - own[O_LAST] - 1
    own[O_READ] += 1
    own[O_LAST] = seq
    own[O_CAPTURE] = capture_ns
    reader[H_READ] = own[O_READ]
    reader[H_DROPPED] = own[O_DROPPED]
    reader[H_LAST] = seq


@njit(cache=True)
def store_fenced(words, index, value):
    words[index] = value
    _fence()


@njit(cache=True)
def fence():
    _fence()


class GrabberMemory:
    """Typed views of the layout over ``buffer`` (anything writable with the buffer protocol)."""

    def __init__(self, buffer, *, create: bool = False, n_slots: int = MIN_SLOTS, clock: int = CLOCK_MONOTONIC):
        self.buffer = buffer
        raw = np.frombuffer(buffer, dtype=np.uint8)
        if create:
            if not MIN_SLOTS <= n_slots <= MAX_SLOTS or raw.size < buffer_bytes(n_slots):
                raise ProtocolError(f"{n_slots} slots need {buffer_bytes(n_slots)} bytes and 4..16 slots; "
                                    f"got {raw.size} bytes")
            raw[:HEADER_BYTES] = 0
            raw[:8] = np.frombuffer(MAGIC, dtype=np.uint8)
        elif raw.size < HEADER_BYTES or raw[:8].tobytes() != MAGIC:
            raise ProtocolError("not a framegrabber buffer (bad magic)")
        for name, offset in _OFFSETS.items():
            setattr(self, name, np.ndarray((_WORDS[name],), dtype="<i8", buffer=buffer, offset=offset))
        if create:
            self.layout[[L_VERSION, L_SLOTS, L_STRIDE, L_DATA, L_CLOCK, L_FIELD_NS]] = (
                VERSION, n_slots, SLOT_HEADER_BYTES + MEMORY_BYTES, MEMORY_BYTES, clock, FIELD_NS)
            self.writer[:] = 0
            self.writer[W_PUBLISHED] = -1
            self.reader[[H_CLAIM, H_HOLD]] = -1
        else:
            _check_layout(self.layout, raw.size)
        self.n_slots = int(self.layout[L_SLOTS])  # (checked above: made so, or by _check_layout)
        stride = int(self.layout[L_STRIDE])
        self.ident = np.ndarray((IDENT_WORDS,), dtype="<i8", buffer=buffer, offset=0)
        self.clock = int(self.layout[L_CLOCK])
        self.slot_headers = [np.ndarray((F_REGS + len(REG_NAMES),), dtype="<i8", buffer=buffer,
                                        offset=HEADER_BYTES + s * stride) for s in range(self.n_slots)]
        self.slot_data = [raw[HEADER_BYTES + s * stride + SLOT_HEADER_BYTES: HEADER_BYTES + (s + 1) * stride]
                          for s in range(self.n_slots)]

    def words(self, slot: int, settings: GrabberSettings) -> np.ndarray:
        """Zero-copy view of a slot's packed pixels, (rows, words_per_row)."""
        dtype = np.dtype(f"<u{settings.word_bits // 8}")
        return self.slot_data[slot][:settings.frame_bytes].view(dtype).reshape(settings.rows, settings.words_per_row)


def _check_layout(layout, size: int) -> None:
    """The device's layout words, before any of them sizes a view (ProtocolError naming the word)."""
    version, n_slots, stride, data, clock, field_ns = (int(v) for v in layout[:6])
    if version != VERSION:
        raise ProtocolError(f"framegrabber buffer version {version}, this end speaks {VERSION}")
    if not MIN_SLOTS <= n_slots <= MAX_SLOTS:
        raise ProtocolError(f"framegrabber layout: {n_slots} slots, expected {MIN_SLOTS}..{MAX_SLOTS}")
    if data != MEMORY_BYTES:
        raise ProtocolError(f"framegrabber layout: {data} data bytes per slot, expected {MEMORY_BYTES}")
    if stride < SLOT_HEADER_BYTES + data or stride % 8 or HEADER_BYTES + n_slots * stride > size:
        raise ProtocolError(f"framegrabber layout: slot stride {stride} (at least {SLOT_HEADER_BYTES + data}, "
                            f"a multiple of 8, {n_slots} slots within {size} bytes)")
    if clock not in (CLOCK_MONOTONIC, CLOCK_LOOP):
        raise ProtocolError(f"framegrabber layout: clock {clock}, expected {CLOCK_MONOTONIC} or {CLOCK_LOOP}")
    if field_ns != FIELD_NS:
        raise ProtocolError(f"framegrabber layout: field period {field_ns} ns, expected {FIELD_NS}")


def encode(settings: GrabberSettings, trigger: int = 0) -> list[int]:
    x, y, w, h = settings.window
    return [settings.density_h, settings.density_v, x, y, w, h, SCANS.index(settings.scan), settings.offset,
            settings.gain, settings.levels, settings.word_bits, settings.shots, trigger]


def decode(words) -> GrabberSettings:
    """Registers → settings; :class:`rtctl.errors.SettingsError` for a combination the device cannot do."""
    v = [int(x) for x in words[:len(REG_NAMES)]]
    scan = SCANS[v[6]] if 0 <= v[6] < len(SCANS) else f"<scan code {v[6]}>"
    return GrabberSettings(density=(v[0], v[1]), window=(v[2], v[3], v[4], v[5]), scan=scan, offset=v[7],
                           gain=v[8], levels=v[9], word_bits=v[10], shots=v[11])


class DevicePort:
    """The device's end: read the registers, reserve a slot, publish a frame."""

    def __init__(self, memory: GrabberMemory):
        self.m = memory
        self._next = 0
        self.seq = 0
        self.skipped = 0  # frames with no free slot (the host would have to hold three at once)

    def registers(self) -> tuple[int, list[int]] | None:
        """(generation, register words) if a consistent set is there (never waits)."""
        regs = self.m.regs
        gen = int(regs[R_GEN])
        if gen == 0 or gen & 1:
            return None
        words = regs[1:].tolist()
        fence()
        return (gen, words) if int(regs[R_GEN]) == gen else None

    def reserve(self) -> int:
        slot = _reserve(self.m.writer, self.m.reader, self.m.n_slots, self._next)
        if slot < 0:
            self.skipped += 1
        else:
            self._next = (slot + 1) % self.m.n_slots
        return slot

    def abandon(self, slot: int) -> None:
        """Give a reserved slot back unpublished (its image could not be completed)."""
        self.m.writer[W_SEQ0 + slot] = 0

    def publish(self, slot: int, capture_ns: int, field: str, gen: int, words: list[int], nbytes: int) -> int:
        self.seq += 1
        h = self.m.slot_headers[slot]
        h[:F_REGS] = (self.seq, capture_ns, FIELD_CODES[field], gen, nbytes)
        h[F_REGS:] = words
        _publish(self.m.writer, slot, self.seq)
        return self.seq

    def set_status(self, state: int, applied_gen: int | None = None, error: int | None = None) -> None:
        s = self.m.status
        s[S_STATE] = state
        if applied_gen is not None:
            s[S_APPLIED] = applied_gen
        if error is not None:
            s[S_ERROR] = error
