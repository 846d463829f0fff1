"""The CAN bus of a joint device: python-can options from the run configuration, and the
bus-load budget of every bus of a run (docs/can_joints.md).

::

    [devices.bus]                 # can.Bus(**bus): the interface and any keyword it takes
    interface = "socketcand"
    host = "127.0.0.1"
    port = "${HIL_SIM_PORT}"      # ${VAR} / ${VAR:-default}: from the environment at start-up
    channel = "can0"
    bitrate = 1000000             # also the budget's bitrate (default 1 Mbit/s, said so)
    tcp_tune = true

A string value may name environment variables; after expansion, a value that is an integer
literal becomes an integer (ports, bitrates). This is how a run configuration reaches a
simulator whose port or pty is only known when it starts: ``hil-sim`` prints the variables
to set (its ``env`` field). ``timeout`` (slcan's serial read timeout) must be seconds ≥ 0: the
driver times its reads by it. Devices whose bus options name the same interface, channel, host
and port share one bus: the budget counts their joints together.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import can

from rtctl.busload import DEFAULT_LIMIT, BusLoad, ProtocolFrames, bus_load, check_bus_load, format_budget
from rtctl.tomltable import Deferred, Table, expand_env

DEFAULT_BITRATE = 1_000_000


class PartialReads(logging.Filter):
    """python-can's socketcand interface warns "Got incomplete message" whenever a TCP read
    ends inside a frame — normal for a stream, and it waits for the rest. Counted here, not
    printed (a loaded machine printed hundreds of these into the run's log and `bench can`)."""

    count = 0

    def filter(self, record: logging.LogRecord) -> bool:
        if record.msg == "Got incomplete message => waiting for more data":
            PartialReads.count += 1
            return False
        return True


logging.getLogger("can.interfaces.socketcand.socketcand").addFilter(PartialReads())
BUDGET_KEY = "can_bus_budget"  # in DeviceContext.shared


@dataclass(frozen=True)
class BusOptions:
    kwargs: dict  # for can.Bus(**kwargs)
    bitrate: int  # for the budget
    bitrate_assumed: bool
    identity: tuple  # (interface, channel, host, port): equal for devices on one bus
    label: str

def read_bus_options(t: Table) -> BusOptions:
    """The ``bus`` sub-table of the device table ``t``, validated (nothing is opened). While
    ``rtctl check`` defers unset variables, the values that name one are not checked here."""
    bt = t.table("bus")
    kwargs = {}
    for key in list(bt.data):
        value = bt.raw(key)
        if not isinstance(value, (str, int, float, bool)):  # (the TOML has no NaN: load_toml refused it)
            raise bt.error(key, f"a string, number or true/false for can.Bus({key}=...), got {value!r}")
        kwargs[key] = expand_env(bt, key, value) if isinstance(value, str) else value
    deferred = {k for k, v in kwargs.items() if isinstance(v, Deferred)}
    interface = kwargs.get("interface")
    if "interface" not in deferred and (not isinstance(interface, str) or interface not in can.interfaces.VALID_INTERFACES):
        raise bt.error("interface", f"a python-can interface ({', '.join(sorted(can.interfaces.VALID_INTERFACES))}), "
                                    f"got {interface!r}")
    channel = kwargs.get("channel")
    if "channel" not in deferred and (not isinstance(channel, (str, int)) or channel == ""):
        raise bt.error("channel", f"the channel to open (a name, a tty, or an index), got {channel!r}")
    host, port = kwargs.get("host"), kwargs.get("port")
    if interface == "socketcand":
        if "host" not in deferred and (not isinstance(host, str) or not host):
            raise bt.error("host", f"the socketcand server's host, got {host!r}")
        if "port" not in deferred and (not isinstance(port, int) or isinstance(port, bool) or not 0 < port < 65536):
            raise bt.error("port", f"a TCP port 1…65535, got {port!r}")
    timeout = kwargs.get("timeout")  # (the TOML loader has refused a non-finite one)
    if "timeout" not in deferred and timeout is not None and (
            not isinstance(timeout, (int, float)) or isinstance(timeout, bool) or timeout < 0):
        raise bt.error("timeout", f"a number of seconds ≥ 0, got {timeout!r}")
    bitrate = None if "bitrate" in deferred else kwargs.get("bitrate")
    if bitrate is not None and (not isinstance(bitrate, int) or isinstance(bitrate, bool) or bitrate <= 0):
        raise bt.error("bitrate", f"a positive integer (bit/s), got {bitrate!r}")
    label = str(channel)
    return BusOptions(kwargs, bitrate or DEFAULT_BITRATE, bitrate is None,
                      (interface, str(channel), host, port), label)


@dataclass
class _Bus:
    label: str
    protocol: str
    bitrate: int
    bitrate_assumed: bool
    frames: ProtocolFrames | None = None  # None: the protocol's standard frames
    joints: int = 0
    devices: list = field(default_factory=list)
    ids: dict = field(default_factory=dict)  # CAN id → who sends (a drive) or listens (a master_id) on it
    replies: dict = field(default_factory=dict)  # (master_id, reply byte 0) → the joint it names

    def load(self, rate_hz: float) -> BusLoad:
        return bus_load(self.label, self.protocol, self.joints, rate_hz, self.bitrate, self.frames)


class BusBudget:
    """Every CAN bus of one run and the joints on it (one instance in ``DeviceContext.shared``).
    :meth:`add` refuses a bus loaded beyond its limit at the loop rate (BusLoadError, exit 2)."""

    def __init__(self):
        self.buses: dict[tuple, _Bus] = {}
        self.limits: dict[tuple, float] = {}

    @classmethod
    def of(cls, shared: dict) -> tuple["BusBudget", bool]:
        """The run's budget, and whether the caller created it (and so reports it)."""
        if BUDGET_KEY in shared:
            return shared[BUDGET_KEY], False
        shared[BUDGET_KEY] = budget = cls()
        return budget, True

    def add(self, t: Table, device: str, bus: BusOptions, protocol: str, joints: int, rate_hz: float,
            limit: float = DEFAULT_LIMIT, frames: ProtocolFrames | None = None) -> BusLoad:
        """``frames``: what one joint (and the bus) costs per tick, when not the protocol's standard."""
        entry = self.buses.get(bus.identity)
        if entry is None:
            entry = self.buses[bus.identity] = _Bus(bus.label, protocol, bus.bitrate, bus.bitrate_assumed, frames)
        elif entry.protocol != protocol or entry.bitrate != bus.bitrate or entry.frames != frames:
            raise t.error("protocol", f"the protocol and bitrate of the other devices on bus {bus.label} "
                                      f"({entry.protocol}, {entry.bitrate} bit/s), got {protocol}, {bus.bitrate} bit/s")
        entry.joints += joints
        entry.devices.append(device)
        self.limits[bus.identity] = min(limit, self.limits.get(bus.identity, limit))
        load = entry.load(rate_hz)
        return check_bus_load(load, t.file, f"{t.path}.bus", self.limits[bus.identity])

    def claim_ids(self, t: Table, device: str, bus: BusOptions, commands: dict, master_id: int, replies: dict) -> None:
        """Reserve this device's CAN ids on its bus, or refuse them (ConfigError, exit 2) when
        they would be confused with another device's there: ``commands`` (drive id → joint)
        must be ids nobody else sends or listens on, ``master_id`` (the id the drives reply
        on) no other device's drive id, and ``replies`` (reply byte 0 → joint) unique among
        the devices listening on the same ``master_id``."""
        entry = self.buses[bus.identity]
        for can_id, joint in commands.items():
            if can_id in entry.ids:
                raise t.error("ids", f"CAN ids no other device on bus {bus.label} uses; {can_id:#x} (joint {joint}) "
                                     f"is also {entry.ids[can_id]}")
        if not entry.ids.get(master_id, "master_id").startswith("master_id"):
            raise t.error("master_id", f"an id no other device's drive on bus {bus.label} uses; {master_id:#x} is "
                                       f"{entry.ids[master_id]}")
        for key, joint in replies.items():
            other = entry.replies.get((master_id, key))
            if other is not None:
                raise t.error("ids", f"drives whose replies can be told apart on bus {bus.label} (master_id "
                                     f"{master_id:#x}); joint {joint} and {other} both answer with byte 0 = {key:#04x}")
        entry.ids.update({can_id: f"drive {can_id:#x} of {device} (joint {joint})" for can_id, joint in commands.items()})
        entry.ids.setdefault(master_id, f"master_id of {device}")
        entry.replies.update({(master_id, key): f"joint {joint} of {device}" for key, joint in replies.items()})

    def lines(self, rate_hz: float) -> list[str]:
        """The table ``rtctl check`` prints, one row per bus (a note when a bitrate is assumed)."""
        loads = [b.load(rate_hz) for b in self.buses.values()]
        limit = min(self.limits.values(), default=DEFAULT_LIMIT)
        lines = format_budget(loads, limit).split("\n")
        for b in self.buses.values():
            if b.bitrate_assumed:
                lines.append(f"  {b.label}: no bitrate in its bus options, {b.bitrate / 1e3:g} kbit/s assumed")
            if len(b.devices) > 1:
                lines.append(f"  {b.label}: shared by devices {', '.join(b.devices)}")
        return lines
