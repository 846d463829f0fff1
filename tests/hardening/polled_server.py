"""A ControlServer polled every millisecond from a thread standing in for the daemon's loop,
and a client connect that waits while the server's accept queue is full."""
from __future__ import annotations

import socket
import threading
import time

from rtctl.control_socket import ControlServer


class PolledServer:
    """Serves ``path``; ``check(request)`` (optional) sees every request the handler gets and
    returns False for one that should never have reached it (kept in ``bad``)."""

    def __init__(self, path, check=None, **kwargs):
        self.calls, self.bad = [], []
        self._check = check
        self.server = ControlServer(path, self._handle, n_joints=6, **kwargs)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _handle(self, req):
        self.calls.append(req["cmd"])
        if self._check is not None and not self._check(req):
            self.bad.append(req)
        return {}

    def _run(self):
        while not self._stop.is_set():
            self.server.poll()
            time.sleep(0.001)

    def close(self):
        self._stop.set()
        self._thread.join()
        self.server.close()


def connect(path, timeout: float = 5.0) -> socket.socket:
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(timeout)
    end = time.monotonic() + timeout
    while True:
        try:
            s.connect(str(path))
            return s
        except BlockingIOError:  # the accept queue is full until the next poll
            if time.monotonic() > end:
                s.close()
                raise
            time.sleep(0.001)
