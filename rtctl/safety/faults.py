"""What the safety stage decides and records: verdicts, fault kinds, latched fault records,
and the protocol of the interference guard's run-time hook."""
from __future__ import annotations

import enum
from dataclasses import asdict, dataclass
from typing import Protocol

from rtctl.hal.joints import JointCommand, JointState
from rtctl.hal.lifecycle import Status
from rtctl.safety import kernels as k


class Verdict(enum.IntEnum):
    """What the loop does with this tick's command (returned by ``SafetyStage.check``)."""

    OK = 0  # controllers in charge; the command (possibly clamped) goes out
    FALLBACK = 1  # a fault is latched: the stage wrote the fallback command; drives stay enabled,
    #               controllers are not in charge (their output is overwritten every tick)
    DEACTIVATE = 2  # stop complete (or category 0): command is zero, deactivate every device now;
    #                 repeated every tick until a successful reset()


class FaultKind(enum.IntFlag):
    POSITION = k.POSITION  # past a hard joint limit
    VELOCITY = k.VELOCITY  # |q̇| over the limit
    NONFINITE_STATE = k.NONFINITE_STATE  # the device reported NaN/inf
    STALE = k.STALE  # no fresh data for stale_ticks consecutive ticks
    DEVICE_ERROR = k.DEVICE_ERROR  # a device's read/write returned ERROR
    DEVICE_DEACTIVATE = k.DEVICE_DEACTIVATE  # a device asked to be deactivated (its own stop)
    NONFINITE_COMMAND = k.NONFINITE_COMMAND  # a controller wrote NaN/inf
    CONTROLLER = k.CONTROLLER  # a controller raised
    GUARD = k.GUARD  # the guard hook refused the command
    ESTOP = k.ESTOP  # e-stop (operator, control socket, overrun policy)
    FOLLOWING = k.FOLLOWING  # |q_ref − q| over the window for following_ticks consecutive ticks


#: faults that stop like an e-stop (category 1: damping, then drives off) rather than hold
STOPPING = FaultKind.ESTOP | FaultKind.DEVICE_DEACTIVATE


@dataclass(frozen=True)
class Fault:
    kind: FaultKind
    joint: int  # -1 when the fault is not a joint's
    tick: int
    t: float
    value: float  # the offending value (position, velocity, stale ticks, status code…); NaN if none
    reason: str

    def as_dict(self) -> dict:
        d = asdict(self)
        d["kind"] = self.kind.name.lower()
        return d


def device_reason(device, status: int) -> str:
    """A device fault's reason: the device by its configured name and the cause as its driver
    saw it (``fault_cause()``), e.g. ``device arm failed: bus can0: CanOperationError: …``. For
    the fault path only (it allocates)."""
    what = "stopped itself" if status == Status.DEACTIVATE else "failed"
    try:
        cause = device.fault_cause()
    except Exception as e:  # a reason must come out of a fault, whatever the driver does
        cause = f"(its cause could not be read: {type(e).__name__}: {e})"
    return f"device {device.name} {what}: {cause}"


class GuardVerdict(enum.IntEnum):
    PASS = 0  # command untouched
    MODIFIED = 1  # the guard changed the command in place (the stage bounds it again)
    STOP = 2  # violation: the stage latches a GUARD fault (reason from ``guard.reason``)


class Guard(Protocol):
    """Run-time hook of the interference guard (docs/interference_guard.md): called every
    tick the controllers are in charge, after the command is bounded, before it is written."""

    reason: str
    event_due: bool  # optional: True on the tick a violation episode starts; the stage then emits
    #                  a ``guard`` event with the fields of ``event()``

    def check(self, t: float, state: JointState, command: JointCommand) -> int:
        """Return a :class:`GuardVerdict`; may modify ``command`` in place; must not allocate."""

    def event(self) -> dict:
        """The fields of the ``guard`` event (called only when ``event_due``)."""
