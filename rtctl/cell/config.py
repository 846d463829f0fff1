"""The cell file: several robots, each a run configuration, coordinated over Zenoh (docs/cell.md).

Validated like a run configuration: an error names the file, the key path and what was
expected (ConfigError, exit 2). The network defaults are the safe ones and are written here,
not left to Zenoh: peer mode, loopback endpoints only, multicast scouting off, and Zenoh's own
user/password authentication on every link.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rtctl.errors import ConfigError
from rtctl.tomltable import Table, load_toml

NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,62}")  # a single Zenoh key chunk: no '/', '*', '$', '?' or '#'
LOOPBACK = "127.0.0.1"
DEFAULT_STATE_RATE_HZ = 100.0
DEFAULT_STATUS_RATE_HZ = 1.0
DEFAULT_LEASE_S = 5.0
# SCHED_FIFO priority of the processes on the e-stop's path (the bridges, the arbiter, `rtctl cell`
# commands): above the machine's ordinary work, below the loops (80) and hil-sim's drives (70)
DEFAULT_BRIDGE_PRIORITY = 60
DEFAULT_LEASE_MARGIN_S = 0.25
ARBITER = "arbiter"  # the key chunk of the shared zones' arbiter (rtctl/<cell>/arbiter/cmd/lease): no robot's name


@dataclass(frozen=True)
class CellRobot:
    name: str
    config: Path  # the run configuration, absolute
    base: np.ndarray  # the robot's base pose in the cell: x, y, z (m), roll, pitch, yaw (rad)
    host: str  # its bridge listens on tcp/<host>:<port>
    port: int
    sim: bool  # `rtctl run --sim`

    def endpoint(self) -> str:
        return f"tcp/{self.host}:{self.port}"


@dataclass(frozen=True)
class SharedRegion:
    """The configurations in which ``robot`` is inside the shared zone: a guard zone's part
    (:class:`~rtctl.guard.zones.Box` or :class:`~rtctl.guard.zones.Polygon`, in rad/m)."""

    robot: str
    part: object


@dataclass(frozen=True)
class SharedZone:
    name: str
    regions: tuple  # of SharedRegion, one per robot that can reach the zone


@dataclass(frozen=True)
class ZenohSettings:
    host: str  # the address a robot's bridge listens on unless the robot says otherwise
    connect: tuple  # extra endpoints to connect to (a router on another host), e.g. "tcp/10.0.0.2:7447"
    multicast_scouting: bool


@dataclass(frozen=True)
class CellAuth:
    user: str  # the cell's processes: may command and observe
    dictionary_file: Path  # "user:password" lines: Zenoh's usrpwd dictionary
    observers: tuple  # users of the dictionary that may subscribe but not command

    def password(self) -> str:
        """This user's password, read from the dictionary when a session opens (never kept in
        the configuration object, so it is never logged with it)."""
        try:
            lines = self.dictionary_file.read_text().splitlines()
        except OSError as e:
            raise ConfigError(self.dictionary_file, "", f"a readable user:password file ({e.strerror or e})") from None
        for line in lines:
            user, sep, password = line.partition(":")
            if sep and user == self.user:
                return password
        raise ConfigError(self.dictionary_file, "", f"a line '{self.user}:PASSWORD' for auth.user {self.user!r}")


@dataclass(frozen=True)
class CellConfig:
    file: Path
    name: str
    robots: tuple  # of CellRobot
    zones: tuple  # of SharedZone (enforced by leases: docs/cell.md); () unless check_robots
    zenoh: ZenohSettings
    auth: CellAuth
    state_rate_hz: float
    status_rate_hz: float
    run_dir: Path  # control sockets, telemetry, summaries and logs of the cell's processes
    lease_s: float = DEFAULT_LEASE_S  # a shared zone's lease, d
    lease_margin_s: float = DEFAULT_LEASE_MARGIN_S  # the arbiter counts a lease held until grant + d + m
    bridge_priority: int = DEFAULT_BRIDGE_PRIORITY  # 0: the ordinary scheduler

    def robot(self, name: str) -> CellRobot:
        for r in self.robots:
            if r.name == name:
                return r
        raise ValueError(f"cell {self.name!r} has no robot {name!r}")

    def key(self, robot: str, *parts: str) -> str:
        """``rtctl/<cell>/<robot>/<parts…>`` (``robot`` may be ``*``)."""
        return "/".join(("rtctl", self.name, robot, *parts))


def _name(t: Table, key: str, what: str) -> str:
    value = t.str(key)
    if not NAME.fullmatch(value):
        raise t.error(key, f"a {what} name of letters, digits, '_' or '-' starting with a letter "
                           f"(it is a Zenoh key chunk), got {value!r}")
    return value


def _host(t: Table, default: str) -> str:
    host = t.str("host", default)
    if not re.fullmatch(r"\d{1,3}(\.\d{1,3}){3}", host) or any(int(x) > 255 for x in host.split(".")):
        raise t.error("host", f"an IPv4 address to listen on (default {default}), got {host!r}")
    return host


def _port(t: Table, key: str) -> int:
    return t.int(key, min=1024, max=65535)


def _zenoh(t: Table | None) -> ZenohSettings:
    if t is None:
        return ZenohSettings(LOOPBACK, (), False)
    host = _host(t, LOOPBACK)
    connect = t.raw("connect", [])
    if not isinstance(connect, list) or not all(isinstance(e, str) and re.fullmatch(r"(tcp|tls|quic)/\S+:\d+", e)
                                                for e in connect):
        raise t.error("connect", f"an array of endpoints such as \"tcp/10.0.0.2:7447\", got {connect!r}")
    scouting = t.bool("multicast_scouting", False)
    t.done()
    return ZenohSettings(host, tuple(connect), scouting)


def _auth(t: Table, base: Path) -> CellAuth:
    user = t.str("user")
    if not user or ":" in user:
        raise t.error("user", f"a user name without ':', got {user!r}")
    dictionary = (base / t.str("dictionary_file")).resolve()
    if not dictionary.is_file():
        raise t.error("dictionary_file", f"an existing file of user:password lines (relative to the cell "
                                         f"file's folder); {dictionary} not found")
    observers = t.raw("observers", [])
    if not isinstance(observers, list) or not all(isinstance(o, str) and o and ":" not in o for o in observers) \
            or user in observers:
        raise t.error("observers", f"an array of user names (not the cell's user {user!r}), got {observers!r}")
    t.done()
    return CellAuth(user, dictionary, tuple(observers))


def _robot(t: Table, base: Path, check_robots: bool, default_host: str):
    name = _name(t, "name", "robot")
    if name == ARBITER:
        raise t.error("name", f"a robot name other than {ARBITER!r} (the shared zones' arbiter has that key)")
    config = (base / t.str("config")).resolve()
    if not config.is_file():
        raise t.error("config", f"a run configuration (relative to the cell file's folder); {config} not found")
    pose = t.vector("base", 6, [0, 0, 0, 0, 0, 0])
    host = _host(t, default_host)
    port = _port(t, "port")
    sim = t.bool("sim", False)
    t.done()
    model = None
    if check_robots:
        from rtctl.config import load_config

        model = load_config(config, sim=sim).model  # its own errors name its own file
    return CellRobot(name, config, pose, host, port, sim), model


def _zone(t: Table, models: dict) -> SharedZone:
    """A shared zone; each robot's region is read as a part of a guard zone is, in the zone's
    ``unit`` ("rad" or "deg", for the revolute joints)."""
    from rtctl.guard.config import unit_scale, zone_part

    name = _name(t, "name", "zone")
    unit = t.str("unit", "rad", choices=("rad", "deg"))
    regions = []
    for r in t.tables("regions"):
        robot = r.str("robot")
        if robot not in models:
            raise r.error("robot", f"zone {name!r}: one of the cell's robots ({', '.join(models)}), got {robot!r}")
        if any(x.robot == robot for x in regions):
            raise r.error("robot", f"zone {name!r}: one region per robot; {robot!r} has two")
        model = models[robot]
        regions.append(SharedRegion(robot, zone_part(r, name, model, unit_scale(model, unit))))
        r.done()
    if len(regions) < 2:
        raise t.error("regions", f"zone {name!r}: a region for each of at least two robots (a zone one robot "
                                 "reaches is that robot's own zone: [[guard.zones]] in its run configuration)")
    t.done()
    return SharedZone(name, tuple(regions))


def load_cell(path, *, check_robots: bool = True) -> CellConfig:
    """Parse and validate a cell file; ``check_robots`` also loads each robot's run
    configuration (``cell up``; the commands that only talk to a running cell skip it)."""
    path = Path(path)
    t = load_toml(path)
    base = path.parent
    cell = t.table("cell")
    name = _name(cell, "name", "cell")
    state_rate = cell.float("state_rate_hz", DEFAULT_STATE_RATE_HZ, min=1.0, max=1000.0)
    status_rate = cell.float("status_rate_hz", DEFAULT_STATUS_RATE_HZ, min=0.1, max=100.0)
    run_dir = (base / cell.str("run_dir", f"../../runs/cell/{name}")).resolve()
    bridge_priority = cell.int("bridge_priority", DEFAULT_BRIDGE_PRIORITY, min=0, max=98)
    cell.done()
    leases = t.table("leases", None)
    lease_s, lease_margin_s = DEFAULT_LEASE_S, DEFAULT_LEASE_MARGIN_S
    if leases is not None:
        lease_s = leases.float("duration_s", DEFAULT_LEASE_S, min=0.05, max=60.0)
        lease_margin_s = leases.float("margin_s", DEFAULT_LEASE_MARGIN_S, min=0.0, max=60.0)
        leases.done()
    zenoh = _zenoh(t.table("zenoh", None))
    auth = _auth(t.table("auth"), base)
    robots_t = t.tables("robots")
    if not robots_t:
        raise t.error("robots", "at least one [[robots]] table")
    robots, models = [], {}
    for r in robots_t:
        robot, model = _robot(r, base, check_robots, zenoh.host)
        if robot.name in models:
            raise r.error("name", f"a name no other robot of the cell has; {robot.name!r} is taken")
        if any(x.endpoint() == robot.endpoint() for x in robots):
            raise r.error("port", f"an endpoint no other robot of the cell listens on; {robot.endpoint()} is taken")
        robots.append(robot)
        models[robot.name] = model
    zones = ()
    if check_robots:  # (a region is read against its robot's model)
        zones = tuple(_zone(z, models) for z in t.tables("zones", []))
        if len({z.name for z in zones}) != len(zones):
            raise t.error("zones", "each shared zone named once")
    else:
        t.raw("zones", None)
    t.done()
    return CellConfig(path, name, tuple(robots), zones, zenoh, auth, state_rate, status_rate, run_dir, lease_s,
                      lease_margin_s, bridge_priority)
