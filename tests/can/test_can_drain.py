"""The drain before a tick's frames go out: every frame already received is taken, past slcan's
acknowledgement lines (python-can returns them as None, at once), and it stops at an empty port
(a None that took the serial timeout) — not after as many reads as acknowledgements could be due."""
import time

import can
import pytest

from drivers.can_bus import BusOptions
from drivers.can_device import CanJointGroup

SERIAL_TIMEOUT = 0.05  # s: an empty read here is told from an acknowledgement even on a loaded machine


class ScriptedBus:
    """recv() plays a script: a Message, "ack" (None at once) or "empty" (None after the timeout)."""

    def __init__(self, script):
        self.script, self.reads = list(script), 0

    def recv(self, timeout=None):
        self.reads += 1
        item = self.script.pop(0) if self.script else "empty"
        if item == "empty":
            time.sleep(SERIAL_TIMEOUT)
            return None
        return None if item == "ack" else item


def group(interface, frames_per_send):
    options = BusOptions(kwargs={"interface": interface, "channel": "x", "timeout": SERIAL_TIMEOUT},
                         bitrate=1_000_000, bitrate_assumed=False, identity=(interface, "x", None, None), label="x")
    g = CanJointGroup("arm", ["a", "b"], options)
    g._acknowledged(frames_per_send)
    return g


def frame(i):
    return can.Message(arbitration_id=0x180 + i, data=bytes([i]), is_extended_id=False)


@pytest.mark.parametrize("script, taken, reads", [
    (["ack", frame(1), "ack", frame(2), "empty"], [1, 2], 5),  # late frames behind acknowledgements
    (["ack", "ack", "empty", frame(3)], [], 3),  # an empty port ends it: frame 3 is the next tick's
    ([], [], 1),  # nothing there: one read
    (["ack"] * 4 + [frame(4)], [], 4),  # no more acknowledgements than a tick sends (3) are skipped
])
def test_slcan_drain_reads_past_acknowledgements_and_stops_at_an_empty_port(script, taken, reads):
    g = group("slcan", 3)
    g.bus = ScriptedBus(script)
    got = []
    g._drain(lambda msg: got.append(msg.data[0]) or 0)
    assert got == taken and g.bus.reads == reads


def test_other_interfaces_stop_at_the_first_none():
    g = group("socketcand", 3)
    g.bus = ScriptedBus([frame(1), "ack", frame(2)])  # (no acknowledgements there: a None is an empty buffer)
    got = []
    g._drain(lambda msg: got.append(msg.data[0]) or 0)
    assert got == [1] and g.bus.reads == 2
