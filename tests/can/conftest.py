"""The CAN transports the back-to-back tests run on, each as a Link: a python-can bus on the
master side and the emulated drives (MitDriveBus, Cia402DriveBus) on the far side of the wire."""
import errno
import socket
import threading
import uuid

import can
import pytest

from drivers.protocols import mit
from hil_sim.cia402_drive import stand_in_cia402_bus
from hil_sim.mit_drive import pump, serve_python_can, stand_in_bus
from hil_sim.slcan import SlcanAdapter
from hil_sim.socketcand import SocketcandServer

TRANSPORTS = ("virtual", "socketcand", "slcan", "socketcan")


class Link:
    def __init__(self, name, bus, drives, lockstep_peer=None):
        self.name, self.bus, self.drives = name, bus, drives
        self._peer = lockstep_peer  # virtual: the drives' side of the bus, pumped in lock-step
        self.ids = sorted(drives.drives)

    def send(self, arbitration_id, data):
        self.bus.send(can.Message(arbitration_id=arbitration_id, data=data, is_extended_id=False))

    def pump(self):
        """Lock-step (virtual): let the drives handle what was sent; elsewhere they serve themselves."""
        if self._peer is not None:
            pump(self.drives, self._peer)

    def collect(self, n, timeout=2.0):
        """Up to n frames (the drives answer at once; the timeout only bounds a failure)."""
        self.pump()
        frames = []
        while len(frames) < n and (msg := self.bus.recv(timeout)) is not None:
            frames.append(msg)
        return frames

    def quiet(self, wait=0.05):
        """True when nothing more arrives (an extra reply would be a protocol violation)."""
        self.pump()
        return self.bus.recv(wait) is None

    def exchange(self, frames):
        for arbitration_id, data in frames:
            self.send(arbitration_id, data)
        return self.collect(len(frames))

    def enter_all(self):
        replies = self.exchange([(i, mit.special_frame(mit.Special.ENTER_MOTOR_MODE)) for i in self.ids])
        assert len(replies) == len(self.ids)
        return replies


def _socketcan_skip_reason():
    try:
        s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    except (AttributeError, OSError) as e:
        code = getattr(e, "errno", None)
        if code == errno.EAFNOSUPPORT:
            return "kernel has no AF_CAN (errno 97, EAFNOSUPPORT): socketcan/vcan unavailable here"
        return f"cannot open a CAN_RAW socket: {e}"
    try:
        s.bind(("vcan0",))
    except OSError as e:
        return f"no vcan0 ({e}); set it up with: modprobe vcan; ip link add dev vcan0 type vcan; ip link set up vcan0"
    finally:
        s.close()
    return None


@pytest.fixture(params=TRANSPORTS)
def link(request):
    ids = [1, 2, 3] if request.param == "slcan" else [1, 2, 3, 4, 5, 6]  # slcan carries 3 joints at 1 kHz, not 6
    yield from _open_link(request.param, stand_in_bus(ids, timeout_s=10.0))  # the watchdog test shortens it


@pytest.fixture(params=("virtual", "socketcand", "socketcan"))
def cia402_link(request):
    yield from _open_link(request.param, stand_in_cia402_bus([1, 2, 3]))


def _open_link(kind, drives):
    stop, cleanup = threading.Event(), []
    if kind == "virtual":
        channel = f"test-{uuid.uuid4()}"
        peer = can.Bus(interface="virtual", channel=channel)
        bus = can.Bus(interface="virtual", channel=channel)
        cleanup.append(peer.shutdown)
        yield Link(kind, bus, drives, lockstep_peer=peer)
    elif kind == "socketcand":
        server = SocketcandServer([drives])
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        host, port = server.address
        bus = can.Bus(interface="socketcand", host=host, port=port, channel="can0", tcp_tune=True)
        cleanup += [server.shutdown, lambda: thread.join(5)]
        yield Link(kind, bus, drives)
    elif kind == "slcan":
        adapter = SlcanAdapter(drives)
        thread = threading.Thread(target=adapter.serve_forever, daemon=True)
        thread.start()
        bus = can.Bus(interface="slcan", channel=adapter.path, sleep_after_open=0, bitrate=1_000_000)
        cleanup += [adapter.shutdown, lambda: thread.join(5)]
        yield Link(kind, bus, drives)
    else:
        reason = _socketcan_skip_reason()
        if reason:
            pytest.skip(reason)
        peer = can.Bus(interface="socketcan", channel="vcan0")
        thread = threading.Thread(target=serve_python_can, args=(drives, peer, stop), daemon=True)
        thread.start()
        bus = can.Bus(interface="socketcan", channel="vcan0")
        cleanup += [stop.set, lambda: thread.join(5), peer.shutdown]
        yield Link(kind, bus, drives)
    bus.shutdown()
    for step in cleanup:
        step()
