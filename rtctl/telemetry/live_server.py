"""The live view's process: the rows the loop commits, served to Foxglove as they arrive.

Started by :class:`rtctl.telemetry.live_view.LiveView` as ``python -m rtctl.telemetry.live_server
CONFIG`` with three inherited fds: the shared ring, the read end of a pipe from the loop
(``C`` + the run's summary when it ends; end-of-file if the loop died) and the write end of a
status pipe (``ok PORT`` once listening, or ``error ERRNO TEXT``). Like the writer it ignores
SIGINT/SIGTERM, drops the loop's real-time scheduling and lowers its priority.

It only reads the ring: ``STORED`` every ``POLL_S``, then the new rows. It never holds a
block — the writer alone releases them — so the loop may reuse the memory of a row it has not
read yet; rows read are kept only if ``STORED`` shows afterwards that the loop had not started
on their slot again (a seqlock's check), and a reader that fell behind skips ahead.
Messages are built only for the channels a viewer subscribes to.
"""
from __future__ import annotations

import json
import os
import re
import select
import sys
import time

import numpy as np

from rtctl.telemetry.channels import EVENTS, LOG_SCHEMA, encode, events, joint_names, messages, topics
from rtctl.telemetry.ring import CTL_BYTES, STORED, Ring
from rtctl.telemetry.schema import row_dtype, schema_from_wire
from rtctl.telemetry.ring_reader import detach_from_loop, read_summary

POLL_S = 0.01  # rows reach a viewer within ~10 ms: well under a display frame
LINGER_S = 0.5  # after the end: the SDK sends what it queued before the server stops


class Publisher:
    """Reads rows of ``ring`` past the last it saw and logs them on the run's channels."""

    def __init__(self, ring: Ring, dtype: np.dtype, meta: dict, foxglove):
        self.ring, self.meta = ring, meta
        self.capacity = ring.block_rows * ring.n_blocks
        self.rows = np.frombuffer(ring.map, dtype=dtype, count=self.capacity, offset=CTL_BYTES)
        shapes = {name: dtype[name].shape for name in dtype.names}
        self.names = joint_names(meta, shapes)
        self.channels = [(topic, foxglove.Channel(topic.topic, schema=topic.schema)) for topic in topics(shapes, meta)]
        self.log = foxglove.Channel(EVENTS, schema=LOG_SCHEMA)
        self.next = 0  # the next row of the run to read
        self.t_first = self.t_last = None

    def poll(self) -> None:
        stored = int(self.ring.ctl[STORED])
        if stored == self.next:
            return
        wanted = [(topic, channel) for topic, channel in self.channels if channel.has_sinks()]
        if not wanted and self.t_first is not None:
            self.next = stored  # nobody looks: nothing to build, only the time for the end events
            self.t_last = float(self.rows["t"][(stored - 1) % self.capacity])
            return
        first = max(self.next, stored - self.capacity + self.ring.block_rows)  # behind: skip to recent rows
        rows = self.rows[np.arange(first, stored) % self.capacity]  # (a copy)
        safe = int(self.ring.ctl[STORED]) - self.capacity + 1  # rows before it may be overwritten
        if safe > first:
            rows = rows[safe - first:]
        self.next = stored
        if not len(rows):
            return
        t = rows["t"].astype(float)
        if self.t_first is None:
            self.t_first = float(t[0])
            self._log_events(events(self.t_first, self.t_first, self.meta, None))
        self.t_last = float(t[-1])
        log_time = np.round(t * 1e9).astype(np.int64).tolist()
        for topic, channel in wanted:
            for ns, message in zip(log_time, messages(topic, self.names, t, rows)):
                channel.log(encode(message), log_time=ns)

    def finish(self, summary) -> None:
        """The last rows, then the run's events after the start (the summary holds them)."""
        self.poll()
        if self.t_first is not None and summary is not None:
            self._log_events(events(self.t_first, self.t_last, self.meta, summary)[1:])

    def _log_events(self, found: list[dict]) -> None:
        for event in found:
            self.log.log(encode(event), log_time=round(event.pop("t") * 1e9))


def serve(publisher: Publisher, pipe_fd: int) -> None:
    """Publish every ``POLL_S`` until the loop closes (``C`` + summary) or dies (end of file)."""
    while True:
        if select.select([pipe_fd], [], [], POLL_S)[0]:
            chunk = os.read(pipe_fd, 65536)
            start = chunk.find(b"C")
            if not chunk or start >= 0:
                publisher.finish(read_summary(pipe_fd, chunk[start + 1:]) if chunk else None)
                return
        publisher.poll()


def main(argv=None) -> int:
    config = json.loads((argv or sys.argv[1:])[0])
    detach_from_loop()
    status = config["status_fd"]
    try:
        import foxglove

        server = foxglove.start_server(name=f"rtctl {config['meta'].get('robot', '')}".strip(),
                                       host=config["host"], port=config["port"])
    except RuntimeError as e:  # the SDK says "... (os error 98)": the errno travels
        code = re.search(r"os error (\d+)", str(e))
        os.write(status, f"error {code.group(1) if code else '-'} {e}\n".encode())
        return 2
    os.write(status, f"ok {server.port}\n".encode())
    os.close(status)
    dtype = row_dtype(schema_from_wire(config["schema"]))
    ring = Ring(config["ring_fd"], dtype, config["block_rows"], config["n_blocks"])
    try:
        serve(Publisher(ring, dtype, config["meta"], foxglove), config["pipe_fd"])
        time.sleep(LINGER_S)
    finally:
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
