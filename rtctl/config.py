"""Run configuration: TOML → validated, frozen dataclasses (docs/architecture.md).

Everything is checked before any device is touched; every error names the file, the key
path and what was expected (:class:`rtctl.errors.ConfigError`, exit code 2 from the CLI).
Sections whose keys belong to a plug-in (a driver's options, a controller's gains) are kept
as :class:`~rtctl.tomltable.Table` here and validated by that plug-in's ``from_config`` —
still before anything is opened (see :mod:`rtctl.daemon`).

Layout of a run configuration (paths are relative to the file)::

    [robot]       description = "robots/puma560.toml"    # D-H TOML or URDF
    [loop]        rate_hz, overrun_limit, spin_us, realtime_factor;  [loop.rt] knobs
    [sim]         present → joint devices are the embedded simulator (see hil_sim.embedded)
    [[devices]]   name, kind ("joints" by default), driver (entry point in rtctl.drivers),
                  joints (kind "joints" only), driver options …
    [[controllers]] name, type, joints ([] for an observer that owns no command), divisor,
                  devices (names of non-joint devices it uses), active (default true:
                  false = built and checked, run only after `rtctl switch`), gains …
    [trajectory]  unit, waypoints, smooth, dwell, velocity/acceleration limits, durations
    [safety]      fallback, damping, stale_ticks, position_margin, estop_off_delay, following_error …
    [guard]       interference zones and the guard's settings (rtctl.guard.config)
    [telemetry]   path, batch_rows, on_failure ("stop": a writer failure is a safe stop; "continue")
    [live]        host (default 127.0.0.1), port (default 8765): serve the run to Foxglove live
    [control]     socket
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rtctl.control.gains import per_joint
from rtctl.control_socket.client import default_socket_path
from rtctl.errors import ConfigError, RtctlError
from rtctl.guard.config import GuardConfig, check_waypoints, load_guard
from rtctl.model import Model, load_robot
from rtctl.telemetry.live_view import LiveConfig, from_table as live_from_table
from rtctl.timing.rt import MAX_TIMER_SLACK_NS, RtSettings
from rtctl.timing.scheduler import OVERRUN_LIMIT, SPIN_MARGIN_NS
from rtctl.tomltable import Table, load_toml
from rtctl.trajectory.planning import MAX_DURATION_S


MIN_RATE_HZ = 1.0  # the loop's slowest rate: a tick is at most 1 s apart
MIN_REALTIME_FACTOR = 0.01
SPIN_US = SPIN_MARGIN_NS / 1e3  # the default spin before each deadline (rtctl/timing/busy.py: why not more)


@dataclass(frozen=True)
class LoopConfig:
    rate_hz: float = 1000.0
    overrun_limit: int = OVERRUN_LIMIT  # consecutive overruns → controlled safe stop
    spin_us: float = SPIN_US  # sleep until deadline − spin, then spin (a quarter period at most by default)
    realtime_factor: float = 1.0  # 0 = as fast as possible (simulated devices only)
    rt: RtSettings = field(default_factory=lambda: RtSettings(gc_freeze=True))  # GC frozen while running

    @property
    def period(self) -> float:
        return 1.0 / self.rate_hz


JOINTS = "joints"  # the device kind that serves the robot's joints


@dataclass(frozen=True)
class DeviceConfig:
    name: str
    driver: str
    joints: tuple[int, ...]  # indices into the robot's joints (none for other kinds)
    options: Table  # driver-specific keys, validated by the driver
    kind: str = JOINTS  # "joints", or another kind (framegrabber, leg board …) reached by name


@dataclass(frozen=True)
class ControllerConfig:
    name: str
    type: str
    joints: tuple[int, ...]
    divisor: int
    options: Table  # controller-specific keys, validated by the controller
    devices: tuple[str, ...] = ()  # non-joint devices it uses, by name
    active: bool = True  # false: configured and checked, started by `rtctl switch`


@dataclass(frozen=True)
class TrajectoryConfig:
    waypoints: np.ndarray  # (k, n) radians / metres
    smooth: bool = True
    dwell: float = 0.0
    velocity_scale: float = 0.5  # fraction of the robot's velocity limits
    max_acceleration: np.ndarray | None = None
    durations: tuple[float, ...] | None = None  # s per motion segment (default: as fast as the limits allow)


@dataclass(frozen=True)
class SafetyConfig:
    fallback: str = "hold"
    damping: float = 5.0  # N·m·s/rad for the fallback
    hold_stiffness: float = 50.0  # N·m/rad for "hold"
    stale_ticks: int = 3
    position_margin: float = 0.0  # rad inside the joint limits
    estop_off_delay: float = 0.2  # s of controlled stop before drives are disabled
    fault_off_delay: float = 1.0  # s the fallback holds after a fault before drives are disabled
    following_error: float | tuple[float, ...] = math.inf  # rad (all joints, or one each): window around the reference
    following_ticks: int = 10  # consecutive ticks outside the window that make a fault


@dataclass(frozen=True)
class Config:
    file: Path
    robot_file: Path
    model: Model
    loop: LoopConfig
    devices: tuple[DeviceConfig, ...]
    controllers: tuple[ControllerConfig, ...]
    trajectory: TrajectoryConfig | None
    safety: SafetyConfig
    sim: Table | None
    telemetry_path: Path | None
    telemetry_batch: int
    socket_path: Path
    telemetry_on_failure: str = "stop"  # writer failed: "stop" (safe stop, exit 3) or "continue" without telemetry
    guard: GuardConfig | None = None  # interference zones (robot file and [guard]), if any
    live: LiveConfig | None = None  # [live]: the Foxglove live view (off unless configured or --live)


def load_config(path, *, sim: bool = False) -> Config:
    """Parse and validate a run configuration; ``sim`` forces the embedded simulator."""
    path = Path(path)
    t = load_toml(path)
    base = path.parent

    robot_t = t.table("robot")
    robot_file = (base / robot_t.str("description")).resolve()
    if not robot_file.exists():
        raise robot_t.error("description", f"{robot_file} not found (paths are relative to the configuration's folder)")
    try:
        model = load_robot(robot_file)
    except ConfigError as e:
        if not e.key_path:  # the file as a whole is wrong: say where it was named
            raise robot_t.error("description", f"{e.expected}; got {robot_file}") from None
        raise
    except RtctlError as e:
        raise robot_t.error("description", f"a valid robot description ({e})") from None
    robot_t.done()

    loop = _loop(t.table("loop", None))
    sim_t = t.table("sim", None)
    if sim and sim_t is None:
        sim_t = Table({}, path, "sim")
    devices = _devices(t, model, sim_t is not None)
    controllers = _controllers(t, model)
    _check_owners(t, controllers)
    trajectory_t = t.table("trajectory", None)
    trajectory = _trajectory(trajectory_t, model)
    guard = load_guard(t.table("guard", None), robot_file, model)
    if trajectory is not None:
        check_waypoints(trajectory_t, guard, trajectory.waypoints)
    safety = _safety(t.table("safety", None), model.nq)
    tele = t.table("telemetry", None)
    telemetry_path, batch, on_failure = None, 500, "stop"
    if tele is not None:
        p = tele.str("path", "")
        telemetry_path = (base / p).resolve() if p else None
        batch = tele.int("batch_rows", 500, min=1, max=100_000)
        on_failure = tele.str("on_failure", "stop", choices=("stop", "continue"))
        tele.done()
    control = t.table("control", None)
    socket_path = default_socket_path()
    if control is not None:
        socket_path = Path(control.str("socket", str(socket_path)))
        control.done()
    live = live_from_table(t.table("live", None))
    if loop.realtime_factor != 1.0 and sim_t is None:
        raise t.error("loop.realtime_factor", "1.0 unless the devices are simulated ([sim] or --sim)")
    t.done()
    return Config(path, robot_file, model, loop, devices, controllers, trajectory, safety, sim_t,
                  telemetry_path, batch, socket_path, on_failure, guard, live)


def _loop(t: Table | None) -> LoopConfig:
    if t is None:
        return LoopConfig()
    rt_t = t.table("rt", None)
    rt = RtSettings(gc_freeze=True)
    if rt_t is not None:
        cpus = rt_t.raw("cpus", [])
        if not isinstance(cpus, list) or not all(isinstance(c, int) and c >= 0 for c in cpus):
            raise rt_t.error("cpus", f"an array of CPU numbers, got {cpus!r}")
        rt = RtSettings(priority=rt_t.int("priority", 0, min=0, max=99), cpus=tuple(cpus),
                        mlockall=rt_t.bool("mlockall", False),
                        timer_slack_ns=rt_t.int("timer_slack_ns", 0, min=0, max=MAX_TIMER_SLACK_NS),
                        gc_freeze=rt_t.bool("gc_freeze", True))
        rt_t.done()
    rate_hz = t.float("rate_hz", 1000.0, positive=True, min=MIN_RATE_HZ, max=100_000.0)
    cfg = LoopConfig(
        rate_hz=rate_hz,
        overrun_limit=t.int("overrun_limit", OVERRUN_LIMIT, min=1, max=1_000_000),
        spin_us=t.float("spin_us", min(SPIN_US, 0.25e6 / rate_hz), min=0.0, max=1e6 / MIN_RATE_HZ),
        realtime_factor=realtime_factor(t.float("realtime_factor", 1.0), t.error, "realtime_factor"),
        rt=rt,
    )
    if cfg.spin_us * 1e-6 > cfg.period / 2:
        # a core kept busy nearly all the time is stopped by Linux (rtctl/timing/busy.py)
        raise t.error("spin_us", f"at most half the period ({cfg.period * 5e5:g} µs at {cfg.rate_hz:g} Hz), got "
                                 f"{cfg.spin_us:g}: the loop would keep its core busy near the share Linux "
                                 "gives SCHED_FIFO threads and be stopped for up to 50 ms each time it crosses it")
    t.done()
    return cfg


def realtime_factor(value: float, error, key: str) -> float:
    """0 (lock-step) or within [MIN_REALTIME_FACTOR, 1000]: a slower pace would leave the loop
    asleep for minutes between ticks."""
    if not (value == 0.0 or MIN_REALTIME_FACTOR <= value <= 1000.0):
        raise error(key, f"0 (as fast as possible) or a number in [{MIN_REALTIME_FACTOR:g}, 1000], got {value!r}")
    return value


def joint_indices(t: Table, key: str, model: Model, *, allow_empty: bool = False) -> tuple[int, ...]:
    """Joint names under ``key`` (default: all joints) → indices into the model."""
    names = t.raw(key, None)
    if names is None:
        return tuple(range(model.nq))
    if not isinstance(names, list) or not (names or allow_empty) or not all(isinstance(x, str) for x in names):
        raise t.error(key, "an array of joint names" if allow_empty else "a non-empty array of joint names")
    unknown = [x for x in names if x not in model.joint_names]
    if unknown:
        raise t.error(key, f"joint names of {model.name} ({', '.join(model.joint_names)}); unknown: {unknown[0]!r}")
    if len(set(names)) != len(names):
        raise t.error(key, "each joint at most once")
    return tuple(model.joint_names.index(x) for x in names)


def _devices(t: Table, model: Model, simulated: bool) -> tuple[DeviceConfig, ...]:
    """``[[devices]]``. With ``[sim]``, a joint device's driver becomes the embedded simulator
    ``sim`` (its options are dropped) and any other kind's driver becomes ``sim_<kind>`` (its
    options are kept: they describe the device, e.g. a framegrabber's settings)."""
    out, owner = [], {}
    for d in t.tables("devices", []):
        name = d.str("name")
        if any(o.name == name for o in out):
            raise d.error("name", f"a device name used once; {name!r} is taken")
        kind = d.str("kind", JOINTS)
        if kind != JOINTS:
            if d.raw("joints", None) is not None:
                raise d.error("joints", f"no joints on a device of kind {kind!r} (only kind {JOINTS!r} serves joints)")
            driver = f"sim_{kind}" if simulated else d.str("driver")
            if simulated:
                d.str("driver", "")
            out.append(DeviceConfig(name, driver, (), d, kind))
            continue
        driver = "sim" if simulated else d.str("driver")
        if simulated:
            d.str("driver", "")  # the real driver is replaced, its options ignored
            d.data = {k: v for k, v in d.data.items() if k in ("name", "driver", "joints", "kind")}
        joints = joint_indices(d, "joints", model)
        for j in joints:
            if j in owner:
                raise d.error("joints", f"joints served by one device; {model.joint_names[j]!r} is also on {owner[j]!r}")
            owner[j] = name
        out.append(DeviceConfig(name, driver, joints, d))
    if not owner:
        if not simulated:
            raise t.error("devices", "at least one [[devices]] table serving joints, or a [sim] table for the "
                          "embedded simulator")
        out.insert(0, DeviceConfig("sim", "sim", tuple(range(model.nq)), Table({}, t.file, "devices[0]")))
        return tuple(out)
    missing = [model.joint_names[j] for j in range(model.nq) if j not in owner]
    if missing:
        raise t.error("devices", f"every joint on a device; not served: {', '.join(missing)}")
    return tuple(out)


def _controllers(t: Table, model: Model) -> tuple[ControllerConfig, ...]:
    out = []
    for c in t.tables("controllers", []):
        out.append(ControllerConfig(
            name=c.str("name"), type=c.str("type"), joints=joint_indices(c, "joints", model, allow_empty=True),
            divisor=c.int("divisor", 1, min=1), devices=_names(c, "devices"), active=c.bool("active", True),
            options=c))
    names = [c.name for c in out]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise t.error(f"controllers[{i}].name", f"a name no other controller has; {name!r} is taken")
    return tuple(out)


def _names(t: Table, key: str) -> tuple[str, ...]:
    names = t.raw(key, [])
    if not isinstance(names, list) or not all(isinstance(x, str) for x in names) or len(set(names)) != len(names):
        raise t.error(key, "an array of distinct device names")
    return tuple(names)



def _check_owners(t: Table, controllers) -> None:
    """One owner per joint command among the active controllers (docs/architecture.md); an
    inactive one may only take over joints the active ones own (a switch moves joints between
    controllers, it never leaves one without or gives one two)."""
    owner = {}
    for i, c in enumerate(controllers):
        if not c.active:
            continue
        for j in c.joints:
            if j in owner:
                raise ConfigError(t.file, f"controllers[{i}].joints",
                                  f"one controller per joint (among the active ones); joint {j} is already owned by {owner[j]!r}")
            owner[j] = c.name
    for i, c in enumerate(controllers):
        loose = [j for j in c.joints if j not in owner]
        if not c.active and loose:
            raise ConfigError(t.file, f"controllers[{i}].joints", f"joints an active controller owns (an inactive "
                              f"one takes them over at a switch); joint {loose[0]} has no active owner")


def _trajectory(t: Table | None, model: Model) -> TrajectoryConfig | None:
    if t is None:
        return None
    unit = t.str("unit", "rad", choices=("deg", "rad"))
    scale = np.where(model.joint_types == 0, np.pi / 180.0, 1.0) if unit == "deg" else np.ones(model.nq)
    wp = t.matrix("waypoints", model.nq) * scale
    for k, w in enumerate(wp):
        bad = np.flatnonzero((w < model.q_min) | (w > model.q_max))
        if bad.size:
            j = bad[0]
            raise t.error(f"waypoints[{k}][{j}]", f"within {model.joint_names[j]}'s limits "
                          f"[{model.q_min[j] / scale[j]:g}, {model.q_max[j] / scale[j]:g}] {unit}")
    acc = t.vector("max_acceleration", model.nq, None, min=1e-6)
    durations = t.vector("durations", None, None)
    if durations is not None and (not np.all((durations > 0) & (durations <= MAX_DURATION_S))
                                  or len(durations) != len(wp)):
        raise t.error("durations", f"{len(wp)} positive numbers (s) up to {MAX_DURATION_S:g}, one per motion "
                                   f"segment from the start through each waypoint")
    cfg = TrajectoryConfig(
        waypoints=wp, smooth=t.bool("smooth", True), dwell=t.float("dwell", 0.0, min=0.0),
        velocity_scale=t.float("velocity_scale", 0.5, positive=True, max=1.0),
        max_acceleration=None if acc is None else acc * scale,
        durations=None if durations is None else tuple(durations.tolist()))
    t.done()
    return cfg


def _safety(t: Table | None, n: int) -> SafetyConfig:
    if t is None:
        return SafetyConfig()
    cfg = SafetyConfig(
        fallback=t.str("fallback", "hold", choices=("hold", "damp")),
        damping=t.float("damping", 5.0, min=0.0),
        hold_stiffness=t.float("hold_stiffness", 50.0, min=0.0),
        stale_ticks=t.int("stale_ticks", 3, min=1),
        position_margin=t.float("position_margin", 0.0, min=0.0),
        estop_off_delay=t.float("estop_off_delay", 0.2, min=0.0),
        fault_off_delay=t.float("fault_off_delay", 1.0, min=0.0),
        following_error=_following_error(t, n),
        following_ticks=t.int("following_ticks", 10, min=1),
    )
    t.done()
    return cfg


def _following_error(t: Table, n: int) -> tuple[float, ...]:
    """``following_error``: one window (rad) for every joint or an array of ``n``, each > 0;
    absent: no following-error check (∞)."""
    window = per_joint(t, "following_error", n, math.inf)
    if not np.all(window > 0):
        raise t.error("following_error", f"positive numbers (rad), got {window.tolist()!r}")
    return tuple(window.tolist())
