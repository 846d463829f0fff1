"""The select() loop under the simulator's servers: a shutdown from another thread or a signal
handler ends serve_forever at once, and a drive bus's deadline runs its service with no frame."""
import signal
import threading
import time

from hil_sim.mit_drive import stand_in_bus
from hil_sim.select_server import DriveBusServer, SelectServer

BACKSTOP_S = 10.0  # a server that missed its wake-up gives up here, so a failure cannot hang


class IdleServer(SelectServer):
    """No files; only a backstop deadline, so just a wake-up can end it early."""

    def __init__(self):
        super().__init__()
        self.rounds = 0
        self.closed = False
        self._backstop = self.clock() + BACKSTOP_S

    def _files(self):
        return [], []

    def _ready(self, readable, now):
        self.rounds += 1

    def _next_deadline(self):
        return self._backstop

    def _service(self, now):
        if now >= self._backstop:
            self._stop = True

    def close(self):
        self.closed = True
        super().close()


def test_shutdown_from_another_thread_returns_serve_forever():
    server = IdleServer()
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    threading.Timer(0.05, server.shutdown).start()
    thread.join(BACKSTOP_S + 5)
    assert not thread.is_alive()
    assert server.clock() < server._backstop, "it ended at the backstop: the wake-up was missed"
    assert server.closed and server.rounds == 1  # one round: the wake-up, not a spin
    server.shutdown()  # after close: harmless


def test_shutdown_from_a_signal_handler_returns_serve_forever():
    server = IdleServer()
    previous = signal.signal(signal.SIGALRM, lambda *_: server.shutdown())
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.05)
        server.serve_forever()  # in the main thread, where the handler runs
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert server.clock() < server._backstop, "it ended at the backstop: the wake-up was missed"
    assert server.closed


class Recorder(DriveBusServer):
    def __init__(self, buses):
        super().__init__(buses)
        self.sent = []

    def _files(self):
        return [], []

    def _ready(self, readable, now):
        pass

    def _frames_out(self, bus, frames):
        self.sent.append((bus.name, list(frames)))
        frames.clear()


def test_a_bus_deadline_runs_its_service_without_any_frame():
    bus = stand_in_bus([1], timeout_s=10.0)
    server = Recorder([stand_in_bus([1], name="quiet"), bus])
    ran = threading.Event()
    due = time.monotonic() + 0.05
    bus.call_at(due, ran.set)  # run from bus.service: the only thing that can wake the loop
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        assert ran.wait(BACKSTOP_S)
        assert time.monotonic() >= due
        assert server.sent and server.sent[0][0] == bus.name  # the serviced bus, not the quiet one
        assert all(name == bus.name for name, _ in server.sent)
    finally:
        server.shutdown()
        thread.join(5)
    assert not thread.is_alive()
