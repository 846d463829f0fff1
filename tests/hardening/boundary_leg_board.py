"""The leg board's input boundary (boundary_fuzz.py): the bytes of its serial line."""
from __future__ import annotations

import contextlib
import fcntl
import os
import select
import termios
import threading
import time
import tty

import numpy as np
from hypothesis import strategies as st

from boundary_fuzz import DeviceBoundary, Expect
from drivers.protocols import leg_board as proto
from rtctl.hal import Status

LIMIT = 32767 * proto.SCALE  # the largest angle a sensor frame carries


class LegBoardBytes(DeviceBoundary):
    """The ``leg_board`` driver on a pty whose far end sends sensor frames with advancing,
    repeated, backwards or arbitrary sequence numbers and any status and channel values,
    frames with a flipped bit, cut frames, command frames and random bytes.

    The test's model of the protocol: only an intact sensor frame whose sequence number
    advances (by 1…127, modulo 256) over the last one taken is taken — its angles published,
    fresh, and its status the board's from then on; a tick without one publishes nothing
    fresh; while the last status taken has the watchdog's bit (or an undefined one), every
    tick is the board's ERROR, else OK."""

    PERIOD = 0.002
    EXAMPLES = [  # issue 25, defects 3 and 4: the same frame again, one from before, the watchdog's lock
        [("frame", "next", 0, [1, 2, 3, 4, 5]), ("frame", "repeat", 0, [9, 9, 9, 9, 9]),
         ("frame", "back", 0, [8, 8, 8, 8, 8]), ("frame", "next", 0, [6, 7, 8, 9, 10])],
        [("frame", "next", 0, [0] * 5), ("frame", "next", proto.WATCHDOG, [0] * 5), ("garbage", b""),
         ("frame", "repeat", 0, [0] * 5), ("frame", "next", 0, [0] * 5)],
    ]

    def steps(self):
        frame = st.tuples(st.just("frame"), st.sampled_from(["next", "repeat", "back"]) | st.integers(0, 255),
                          st.sampled_from([0, 0x0F, proto.WATCHDOG, 0x20, 0x80]) | st.integers(0, 255),
                          st.lists(st.integers(-32768, 32767), min_size=5, max_size=5))
        return st.lists(st.one_of(
            frame,
            st.tuples(st.just("flip"), frame, st.integers(0, 8 * proto.SENSOR_LENGTH - 1)),
            st.tuples(st.just("cut"), frame, st.integers(1, proto.SENSOR_LENGTH - 1)),
            st.tuples(st.just("garbage"), st.binary(max_size=40)),
            st.tuples(st.just("command"), st.integers(0, 255), st.integers(0, 15)),
        ), min_size=1, max_size=12)

    @contextlib.contextmanager
    def open(self):
        from drivers.leg_board import SerialLegBoard

        self.master, self.slave = os.openpty()  # the board's end; the slave stays open here too
        tty.setraw(self.slave)
        board = SerialLegBoard("leg", ["hip", "knee", "ankle"], os.ttyname(self.slave), self.PERIOD,
                               reply_deadline=0.25, exchange_timeout=0.5)
        stop = threading.Event()
        self.seq, self.status = -1, 0  # the model: the last frame taken

        def answer():  # bring-up: a board answering each command with a sensor frame
            while not stop.is_set():
                if select.select([self.master], [], [], 0.01)[0] and os.read(self.master, 4096):
                    self.seq = (self.seq + 1) & 0xFF
                    os.write(self.master, proto.encode_sensor(self.seq, 0, [0.0] * 5))

        board_thread = threading.Thread(target=answer, daemon=True)
        board_thread.start()
        try:
            try:
                board.configure()
                board.activate()
            finally:
                stop.set()
                board_thread.join()
            board.exchange_timeout = 0.002  # nothing answers the lock commands at close: give up soon
            board.read(0.0)  # the frames of the bring-up are taken: from here each tick's are the fuzz's
            assert board.decoder.seq == self.seq, (board.decoder.seq, self.seq)
            yield board
        finally:
            board.close()
            os.close(self.master)
            os.close(self.slave)

    def _send(self, data) -> None:
        """Bytes to the host, there (in the tty's input queue) before the tick reads: a pty hands
        bytes over asynchronously."""
        waiting = np.zeros(1, dtype=np.int32)
        before = self._waiting(waiting)
        os.write(self.master, data)
        end = time.monotonic() + 0.5
        while self._waiting(waiting) < before + len(data) and time.monotonic() < end:
            time.sleep(0.0001)
        while select.select([self.master], [], [], 0)[0]:
            os.read(self.master, 4096)  # the host's commands: read and dropped

    def _waiting(self, out) -> int:
        fcntl.ioctl(self.slave, termios.FIONREAD, out)
        return int(out[0])

    def _frame(self, spec):
        _, seq, status, counts = spec
        seq = {"next": self.seq + 1, "repeat": self.seq, "back": self.seq - 1}.get(seq, seq) & 0xFF
        return seq, status, proto.encode_sensor(seq, status, np.array(counts) * proto.SCALE)

    def inject(self, dev, step) -> Expect:
        kind = step[0]
        fresh, why = None, kind
        if kind == "frame":
            seq, status, data = self._frame(step)
            self._send(data)
            why = f"sensor frame seq {seq} status {status:#04x} after seq {self.seq}"
            if 0 < (seq - self.seq) & 0xFF < 0x80:
                self.seq, self.status = seq, status
                fresh = {"position": np.clip(step[3][:3], -32767, 32767) * proto.SCALE}
        elif kind == "flip":  # CRC-16 detects every one-bit error
            data = bytearray(self._frame(step[1])[2])
            data[step[2] // 8] ^= 1 << step[2] % 8
            self._send(data)
        elif kind == "cut":
            self._send(self._frame(step[1])[2][:step[2]])
        elif kind == "garbage":
            self._send(step[1])
        else:
            self._send(proto.encode_command(step[1], step[2] >> 2, step[2] & 3))
        faulty = bool(self.status & proto.STATUS_FAULTS)
        return Expect(status=Status.ERROR if faulty else Status.OK, stale=() if fresh else range(3), fresh=fresh,
                      why=f"{why} (the board's status {self.status:#04x})")

    def tick(self, dev, k):
        status = dev.read(k * self.PERIOD)
        return max(status, dev.write(k * self.PERIOD))

    def bounds(self, dev):
        fastest = 2 * LIMIT / self.PERIOD  # one period from one end of the range to the other
        return {"position": (-LIMIT, LIMIT), "velocity": (-fastest, fastest)}
