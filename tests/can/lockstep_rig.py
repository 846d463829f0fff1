"""A CAN driver in-process, for its tests: the real driver class on a python-can virtual bus,
emulated drives on the far end answering right after each frame the master sends (pumped in
lock-step), on a clock the test owns, with a 'plant' of arrays the test sets (q, qd) and reads
(tau)."""
import uuid

import can
import numpy as np

from drivers.can_bus import BusOptions
from hil_sim.mit_drive import MappedJointPort, pump


def virtual_bus() -> BusOptions:
    channel = f"test-{uuid.uuid4().hex}"
    return BusOptions({"interface": "virtual", "channel": channel}, 1_000_000, False,
                      ("virtual", channel, None, None), channel)


class SlowWire:
    """Mixed in before :class:`LockStep`: drives behind a wire with latency — while ``hold``,
    they answer when the test pumps them."""

    hold = False

    def _after_send(self):
        if not self.hold:
            super()._after_send()


class LockStep:
    """Mixed in before the driver class; the subclass calls :meth:`_attach` after the driver's __init__."""

    def _attach(self, make_drive, drive_bus_class) -> None:
        """``make_drive(joint, port)`` per joint of the driver, on a MappedJointPort of the arrays."""
        n = len(self.joints)
        self.q, self.qd, self.tau = np.zeros(n), np.zeros(n), np.zeros(n)
        self.drive_list = [make_drive(j, MappedJointPort(self.q, self.qd, self.tau, k, j.direction, j.offset))
                           for k, j in enumerate(self.joints)]
        self.drives = drive_bus_class(self.drive_list)
        self.peer = can.Bus(interface="virtual", channel=self.bus_options.kwargs["channel"])
        self.now = 0.0

    def _after_send(self):
        pump(self.drives, self.peer, now=self.now)

    def _clock(self):
        return self.now

    def tick(self, dt=0.001):
        """One loop tick: read, then write the present command."""
        self.now += dt
        return self.read(self.now), self.write(self.now)


def silence_second_drive(rig) -> list:
    """Run a tick, silence drive 2, run four more: their read statuses (the common stale check)."""
    rig.activate()
    rig.tick()
    rig.drive_list[1].faults.silent = True
    statuses = [rig.tick()[0] for _ in range(4)]
    assert list(rig.state.fresh) == [True, False]
    return statuses


def rigs(cls):
    """A fixture body: yields ``make(...)`` building ``cls`` rigs, closes them all at teardown."""
    made = []

    def make(*args, **kw):
        r = cls(*args, **kw)
        made.append(r)
        return r

    yield make
    for r in made:
        r.close()
        r.peer.shutdown()


class SerialPort:
    """What python-can's slcan bus reads from, as far as the driver looks: the count of bytes
    waiting (here: frames in the rig's virtual bus queue)."""

    def __init__(self, bus):
        self.bus = bus

    @property
    def in_waiting(self) -> int:
        return self.bus.queue.qsize()


def as_over_slcan(r):
    """The rig's bus, as over slcan: acknowledgements (two frames a send) and a serial port."""
    r._acks_per_send = 2
    r.bus.serialPortOrig = SerialPort(r.bus)
