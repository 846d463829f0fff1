"""``hil-sim CONFIG``: the robot of a run configuration — plant and emulated MIT drives — in
its own process, behind a real transport, for ``rtctl run`` to drive (docs/operations.md, "Hardware in the loop").

    hil-sim configs/puma560_hil_socketcand.toml                    # transport from the config
    hil-sim CONFIG --transport socketcand [--host H] [--port N]     # default: the config's port; 0: a free one
    hil-sim CONFIG --transport slcan                                # one pty per bus
    hil-sim CONFIG --realtime-factor 1                              # free-running (default 0: lock-step)
    hil-sim CONFIG --fault silent:3@1000 --fault corrupt:2:0.02     # scripted faults (hil_sim.lockstep)
    hil-sim configs/leg_hil.toml                                    # the leg board on a pty (--transport serial)

Framegrabber devices (``kind = "framegrabber"``) get a free-running camera filming the plant at
the PAL rate, writing into a shared memory created here (its name, when the device's ``shm``
option names a ``${VAR}``, made unique and announced under ``env``).

The drives are those of the configuration's ``mit_can`` and ``cia402`` devices (ids, models or
EDS and scaling, mounting: the same layout the driver reads); devices naming the same bus
options share a bus (a socketcand channel, or a pty), one protocol per bus. A configuration
without CAN devices (an embedded ``[sim]`` one) gets the embedded CAN simulator's MIT drives on
one bus ``can0``. The MIT drives' watchdog is their device's ``drive_timeout`` (20 ms by
default; ``--drive-timeout-ms`` overrides it); a CiA 402 drive's RPDO deadline is what the
driver configures (0x1400 sub 5). Plant options: the ``[sim]``
table when there is one, else its defaults.

Stdout, one JSON object per line: first where it listens, e.g.
``{"transport": "socketcand", "host": "127.0.0.1", "port": 41234, "channels": ["can0"],
"env": {"HIL_SIM_PORT": "41234"}}`` or ``{"transport": "slcan", "ttys": {...}, "env":
{"HIL_SIM_TTY": "/dev/pts/5"}}`` — ``env`` holds the variables the configuration's bus
options name as ``${VAR}`` (set them for ``rtctl run``) — then events (motors on/off, faults),
and on SIGTERM/SIGINT a last ``{"event": "exit", …}`` with every drive's state and counters.

A configuration whose device is a ``leg_board`` gets the prosthetic leg instead: the leg plant
(the ``[sim.leg]`` options if any) and the board's firmware behind a pty
(:mod:`hil_sim.leg_serial`), announced as ``{"transport": "serial", "tty": …, "env":
{"HIL_SIM_TTY": …}}``; faults ``silent:1@N`` (the board stops answering after N commands) and
``drop@N`` (the pty closes).
"""
from __future__ import annotations

import argparse
import errno
import signal
import sys
import threading
from pathlib import Path

from drivers.protocols.cia402_layout import read_cia402_joints, read_eds
from drivers.protocols.mit_layout import read_master_id, read_mit_joints
from hil_sim.can_rig import emulated_cia402_drives, emulated_drives, sim_layout
from hil_sim.embedded import SimPlantHub
from hil_sim.framegrabber import camera_servers
from hil_sim.lockstep import HubCia402Bus, HubDriveBus, PlantHub, ScriptedFault
from rtctl.config import joint_indices
from rtctl import jsonout
from rtctl.errors import RtctlError
from rtctl.timing.rt import RtSettings, apply_rt
from rtctl.model import load_robot
from rtctl.tomltable import ENV_TEMPLATE, Table, load_toml


CAN_DRIVERS = ("mit_can", "cia402")


def emit(event: dict) -> None:
    print(jsonout.dumps(event), flush=True)


class BusPlan:
    """One bus to serve: its drives' layout and how the configuration names it."""

    def __init__(self, raw: dict, name: str, driver: str = "mit_can"):
        self.raw, self.name, self.driver = raw, name, driver
        self.layout: list = []  # (MitJoint or Cia402Joint, plant index)
        self.master_id = 0
        self.drive_timeout = 0.02  # mit_can: the drives' watchdog (the device's drive_timeout)
        self.eds = None  # cia402: the drives' EDS


def plan(path: Path):
    """(model, period, [sim] Table or None, [BusPlan]) from a run configuration."""
    t = load_toml(path)
    robot = t.table("robot")
    model = load_robot(path.parent / robot.str("description"))
    loop = t.table("loop", None)
    period = 1.0 / (loop.float("rate_hz", 1000.0, positive=True) if loop is not None else 1000.0)
    sim = t.table("sim", None)
    buses: dict[tuple, BusPlan] = {}
    for d in t.tables("devices", []):
        driver = d.str("driver", "")
        if driver not in CAN_DRIVERS or sim is not None:
            continue
        indices = joint_indices(d, "joints", model)
        raw = d.table("bus").data
        key = tuple(str(raw.get(k)) for k in ("interface", "channel", "host", "port"))
        bus = buses.get(key)
        if bus is None:
            channel = str(raw.get("channel", f"can{len(buses)}"))
            names = ENV_TEMPLATE.findall(channel)  # a pty named by a variable: call the bus by it
            bus = buses[key] = BusPlan(raw, names[0][0] if names else channel, driver)
        if bus.driver != driver:
            raise d.error("driver", f"the protocol of the other devices on bus {bus.name} ({bus.driver}): one per bus")
        joint_names = [model.joint_names[i] for i in indices]
        if driver == "cia402":
            bus.eds = read_eds(d)[0]
            bus.layout += zip(read_cia402_joints(d, joint_names), indices)
        else:
            bus.master_id = read_master_id(d)
            bus.drive_timeout = d.float("drive_timeout", 0.02, positive=True)
            bus.layout += zip(read_mit_joints(d, joint_names), indices)
    if not buses:
        indices = tuple(range(model.nq))
        bus = buses[()] = BusPlan({"interface": "socketcand", "channel": "can0"}, "can0")
        bus.layout = list(zip(sim_layout(model, indices), indices))
    return model, period, sim, list(buses.values())


def env_names(raw: dict, key: str) -> list[str]:
    """The environment variables a bus option names (``${VAR}``)."""
    value = raw.get(key)
    return [m[0] for m in ENV_TEMPLATE.findall(value)] if isinstance(value, str) else []


def build(args):
    path = Path(args.config)
    model, period, sim, plans = plan(path)
    if sim is None:
        sim = Table({}, path, "sim")
    if args.engine is not None:
        sim = Table({**sim.data, "engine": args.engine}, path, "sim")
    sim.str("transport", "direct")  # (the embedded simulator's choice; not ours)
    plant = SimPlantHub.from_options(sim, model, period, path.parent).plant
    plant.step(0.0)  # load the compiled step before announcing
    hub = PlantHub(plant, period, args.realtime_factor, emit)
    hub.faults = [ScriptedFault.parse(s) for s in args.fault]
    hub.cameras = camera_servers(load_toml(path), plant)
    buses = []
    for p in plans:
        joints, indices = zip(*p.layout)
        if p.driver == "cia402":
            buses.append(HubCia402Bus(emulated_cia402_drives(joints, indices, plant, eds=p.eds), p.name, hub))
        else:
            timeout = p.drive_timeout if args.drive_timeout_ms is None else args.drive_timeout_ms / 1e3
            drives = emulated_drives(joints, indices, plant, timeout_s=timeout, master_id=p.master_id)
            buses.append(HubDriveBus(drives, p.name, hub))
    return hub, plans, buses


def serve_socketcand(args, hub, plans, buses) -> int:
    from hil_sim.socketcand import SocketcandServer

    port = args.port
    if port is None:  # the configuration's port, or the default of its ${VAR:-default}, else a free one
        for p in plans:
            value = p.raw.get("port")
            m = ENV_TEMPLATE.fullmatch(value) if isinstance(value, str) else None
            port = value if isinstance(value, int) else (int(m.group(2)) if m and m.group(2) else None)
            if port is not None:
                break
        port = port or 0
    try:
        server = SocketcandServer(buses, args.host, port)
    except OSError as e:  # in use (another simulator?), an address not of this machine …
        _close_cameras(hub.cameras)
        print(f"hil-sim: cannot listen on {args.host}:{port}: {e.strerror or e}"
              + (" (another hil-sim on that port? --port 0 picks a free one)" if e.errno == errno.EADDRINUSE else ""),
              file=sys.stderr)
        return 2
    hub.drop_connections = server.drop_connections
    info = server.info()
    info["env"] = {}
    for p in plans:
        info["env"].update({name: str(info["port"]) for name in env_names(p.raw, "port")})
        info["env"].update({name: info["host"] for name in env_names(p.raw, "host")})
    _stop_on_signals(server.shutdown)
    emit(_with_cameras(info, hub.cameras))
    try:
        server.serve_forever()
    finally:
        emit({**hub.summary(), "server": server.counters, **_close_cameras(hub.cameras)})
    return 0


def serve_slcan(args, hub, plans, buses) -> None:
    from hil_sim.slcan import SlcanAdapter

    adapters = [SlcanAdapter(b, ack_transmit=not args.no_ack) for b in buses]
    info = {"transport": "slcan", "tty": adapters[0].path, "ttys": {b.name: a.path for b, a in zip(buses, adapters)},
            "env": {name: a.path for p, a in zip(plans, adapters) for name in env_names(p.raw, "channel")}}
    stop = threading.Event()
    _stop_on_signals(stop.set)
    threads = [threading.Thread(target=a.serve_forever, daemon=True) for a in adapters]
    for th in threads:
        th.start()
    emit(_with_cameras(info, hub.cameras))
    try:
        while not stop.wait(0.5):  # (a signal handler runs in the main thread between waits)
            pass
    finally:
        for a in adapters:
            a.shutdown()
        for th in threads:
            th.join(5.0)
        emit({**hub.summary(), "server": [a.counters for a in adapters], **_close_cameras(hub.cameras)})


def _with_cameras(info: dict, cameras) -> dict:
    """Start the free-running cameras; announce their shared memories (and the variables naming them)."""
    for c in cameras:
        c.camera.start()
        info["env"].update(c.env)
    if cameras:
        info["framegrabbers"] = {c.name: c.info() for c in cameras}
    return info


def _close_cameras(cameras) -> dict:
    counters = {c.name: c.camera.counters for c in cameras}
    for c in cameras:
        c.close()
    return {"framegrabbers": counters} if cameras else {}


def leg_board_device(path: Path):
    """The configuration's ``leg_board`` device table, or None."""
    for d in load_toml(path).tables("devices", []):
        if d.data.get("driver") == "leg_board":
            return d
    return None


LEG_WATCHDOG_MS = 20.0  # the leg board's command watchdog is 2.5 × this, unless --drive-timeout-ms


def serve_leg(args, path: Path, device) -> int:
    from hil_sim.leg import leg_plant
    from hil_sim.leg_serial import LegBoardServer

    t = load_toml(path)
    loop = t.table("loop", None)
    period = 1.0 / (loop.float("rate_hz", 1000.0, positive=True) if loop is not None else 1000.0)
    sim = t.table("sim", None)
    if sim is None:
        sim = Table({}, path, "sim")
    if args.engine is not None:  # (as for the arm: a HIL configuration has no [sim] to say it)
        sim = Table({**sim.data, "engine": args.engine}, path, "sim")
    plant = leg_plant(sim, sim.table("leg", Table({}, path, "sim.leg")), period)
    watchdog_ms = LEG_WATCHDOG_MS if args.drive_timeout_ms is None else args.drive_timeout_ms
    server = LegBoardServer(plant, period, args.realtime_factor, watchdog_ms / 1e3 * 2.5, emit)
    server.faults = [ScriptedFault.parse(s) for s in args.fault]
    port = device.data.get("port", "")
    info = {"transport": "serial", "tty": server.path, "period": period,
            "env": {name: server.path for name in env_names({"port": port}, "port")}}
    _stop_on_signals(server.shutdown)
    emit(info)
    try:
        server.serve_forever()
    finally:
        emit(server.summary())
    return 0


def _stop_on_signals(stop) -> None:
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="hil-sim", description=__doc__.split("\n\n")[0],
                                epilog=__doc__.split("\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("config", help="run configuration (TOML) whose robot and CAN devices to play")
    p.add_argument("--transport", choices=("socketcand", "slcan", "serial"),
                   help="default: the configuration's bus interface (serial for a leg board)")
    p.add_argument("--host", default="127.0.0.1", help="socketcand: address to listen on (loopback)")
    p.add_argument("--port", type=int, help="socketcand: TCP port (default: the configuration's, else a free one)")
    p.add_argument("--engine", choices=("rigid", "mujoco"), default=None,
                   help="the plant: rtctl's rigid-body model (default) or MuJoCo, an independent engine (the "
                        "`mujoco` extra); overrides [sim] engine")
    p.add_argument("--realtime-factor", type=float, default=0.0, metavar="F",
                   help="0 (default): lock-step, one period per command set; F > 0: free-running at F × wall clock")
    p.add_argument("--drive-timeout-ms", type=float, default=None,
                   help="the MIT drives' command watchdog (default: their device's drive_timeout, else 20 ms; the leg board's is 2.5 × it; "
                        "a CiA 402 drive's deadline is configured by the driver)")
    p.add_argument("--fault", action="append", default=[], metavar="SPEC",
                   help="silent:ID | corrupt:ID:RATE | error:ID:CODE | drop, ID as N or BUS/N, optional @CYCLES")
    p.add_argument("--no-ack", action="store_true", help="slcan: do not acknowledge transmits (z/Z)")
    p.add_argument("--rt-priority", type=int, default=0, metavar="N",
                   help="run the drives at SCHED_FIFO priority N (1–99; below the loop's) with mlockall and "
                        "1 ns timer slack, where permitted (each knob is reported on stderr); 0: leave alone")
    args = p.parse_args(argv)
    if args.realtime_factor < 0:
        p.error("--realtime-factor must be ≥ 0")
    if args.port is not None and not 0 <= args.port <= 65535:
        p.error(f"--port must be a TCP port, 0–65535 (0: a free one), got {args.port}")
    try:
        for spec in args.fault:
            ScriptedFault.parse(spec)
        leg = leg_board_device(Path(args.config))
        if leg is not None or args.transport == "serial":
            if leg is None:
                raise RtctlError(f"{args.config}: --transport serial serves a leg board; no device has driver 'leg_board'")
            return serve_leg(args, Path(args.config), leg)
        hub, plans, buses = build(args)
    except (RtctlError, ValueError) as e:
        print(f"hil-sim: {e}", file=sys.stderr)
        return 2
    if args.rt_priority:
        for report in apply_rt(RtSettings(priority=args.rt_priority, mlockall=True, timer_slack_ns=1)):
            print(f"hil-sim: rt {report.knob}: {report.status.value} {report.detail}", file=sys.stderr)
    transport = args.transport or plans[0].raw.get("interface")
    if transport == "slcan":
        serve_slcan(args, hub, plans, buses)
    elif transport == "socketcand":
        return serve_socketcand(args, hub, plans, buses)
    else:
        _close_cameras(hub.cameras)
        print(f"hil-sim: the configuration's bus interface is {transport!r}: choose --transport socketcand|slcan",
              file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
