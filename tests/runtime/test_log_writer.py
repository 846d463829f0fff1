"""rtctl.logs.BackgroundStream: the loop's log never waits for its reader (the storm test found a
full stdout pipe stopping the loop); what the reader cannot take is dropped and counted."""
from __future__ import annotations

import io
import threading
import time

from rtctl.logs import BackgroundStream


class Stuck(io.StringIO):
    """A reader that does not read: every write waits until released."""

    def __init__(self):
        super().__init__()
        self.release = threading.Event()

    def write(self, text):
        self.release.wait()
        return super().write(text)


def test_writes_never_wait_for_a_stuck_reader_and_the_overflow_is_counted():
    target = Stuck()
    stream = BackgroundStream(target, max_bytes=1000)
    t0 = time.monotonic()
    for k in range(500):  # 10 kB into a 1 kB queue, the reader stuck
        stream.write(f"line {k:04d} ..\n")
        stream.flush()
    assert time.monotonic() - t0 < 1.0  # (a blocking write would never return)
    target.release.set()
    stream.close()
    text = target.getvalue()
    assert "line 0000" in text and "log line(s) dropped: the log's reader did not keep up" in text
    kept = text.count("line ")
    dropped = int(text.rsplit("rtctl: ", 1)[1].split()[0])
    assert kept + dropped == 500 and dropped > 0


def test_close_writes_everything_queued():
    target = io.StringIO()
    stream = BackgroundStream(target)
    for k in range(100):
        stream.write(f"{k}\n")
    stream.close()
    assert target.getvalue().split() == [str(k) for k in range(100)]
