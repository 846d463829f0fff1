"""``rtctl bench can``: the MIT codec's frames per second, and the CAN driver's tick — the
time ``MitCanJointGroup.read()`` + ``write()`` take (collect the answers to the previous tick's
commands, send one command per joint) — over each CAN transport.

* codec: ``pack_command_into`` (one command into a reused buffer), ``unpack_reply_into``
  (one reply into a preallocated row), and the two together;
* driver: ``drivers.can_joints.MitCanJointGroup`` configured and activated as a run would,
  then ``read()`` and ``write()`` every cycle, timing both; over ``virtual`` in lock-step in
  this process (the embedded simulator's path: the drives answer right after the send), and
  over ``socketcand`` (6 joints) and ``slcan`` (3 joints: python-can reads slcan one byte per
  call) with the drives in their own process (``python -m hil_sim.socketcand|slcan``), as in
  HIL. Paced at ``rate_hz`` with absolute deadlines; a cycle longer than the period is a miss,
  one whose ``read()`` ended at the driver's reply deadline with answers missing is lost.

Goals: socketcand 6-joint read() + write() median ≤ 0.35 ms, p99 ≤ 0.7 ms;
slcan 3 joints at 1 kHz without misses.

The drivers and the simulator are imported inside the functions: ``rtctl`` itself never
imports them (the dependency rule, docs/architecture.md); this benchmark needs both ends of the wire.
"""
from __future__ import annotations

import ctypes
import json
import select
import signal
import subprocess
import sys
import time
import uuid

import numpy as np

GOALS = {"socketcand": {"median_ms": 0.35, "p99_ms": 0.7, "joints": 6}, "slcan": {"misses": 0, "joints": 3, "rate_hz": 1000}}


def bench_codec(frames: int = 50_000) -> dict:
    from drivers.protocols import mit

    model, buf = mit.KATZ, bytearray(8)
    out = np.zeros((1, mit.REPLY_COLUMNS))
    reply = mit.pack_reply(model, 1, 0.3, -1.0, 2.0)
    pack, unpack, clock = mit.pack_command_into, mit.unpack_reply_into, time.perf_counter
    t0 = clock()
    for k in range(frames):
        pack(buf, model, 0.001 * k, 0.5, 20.0, 0.5, 1.0)
    t1 = clock()
    for _ in range(frames):
        unpack(reply, model, out, 0)
    t2 = clock()
    for k in range(frames):
        pack(buf, model, 0.001 * k, 0.5, 20.0, 0.5, 1.0)
        unpack(reply, model, out, 0)
    t3 = clock()
    return {"frames": frames, "pack_per_s": frames / (t1 - t0), "unpack_per_s": frames / (t2 - t1),
            "pack_unpack_pairs_per_s": frames / (t3 - t2)}


def _stats(transport, joints, times_s, misses, rate_hz, lost) -> dict:
    ms = np.asarray(times_s) * 1e3
    return {"transport": transport, "joints": joints, "cycles": len(ms), "rate_hz": rate_hz,
            "median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max()), "misses": misses, "lost": lost}


def _driver(bus_kwargs: dict, joints: int, rate_hz: float | None, cls=None, **kw):
    """A MitCanJointGroup of ``joints`` KATZ drives (ids 1…n) on ``can.Bus(**bus_kwargs)``,
    with the driver's default timing at ``rate_hz`` (None: 1 kHz's)."""
    from drivers.can_bus import BusOptions
    from drivers.can_joints import MitCanJointGroup
    from drivers.protocols.mit import KATZ
    from drivers.protocols.mit_layout import MitJoint

    channel = str(bus_kwargs["channel"])
    options = BusOptions(bus_kwargs, 1_000_000, True,
                         (bus_kwargs["interface"], channel, bus_kwargs.get("host"), bus_kwargs.get("port")), channel)
    group = [MitJoint(f"j{i}", i, KATZ) for i in range(1, joints + 1)]
    return (cls or MitCanJointGroup)("bench", group, options, period=1.0 / (rate_hz or 1000.0), **kw)


def _paced(driver, cycles: int, rate_hz: float | None):
    """Configure and activate ``driver``, run ``cycles`` ticks of ``read()`` + ``write()``
    (impedance commands) paced at ``rate_hz`` with absolute deadlines (None: back to back),
    timing both; then deactivate and close it. Returns (times, misses, lost)."""
    from rtctl.hal import CommandMode, Status

    period = 1.0 / rate_hz if rate_hz else 0.0
    times, misses, lost = [], 0, 0
    clock = time.perf_counter
    driver.configure()
    try:
        driver.activate()
        c = driver.command
        c.mode = CommandMode.IMPEDANCE
        c.q_des[:] = 0.1 * np.arange(driver.n)
        c.qd_des[:], c.kp[:], c.kd[:], c.tau_ff[:] = 0.0, 10.0, 0.5, 0.0
        start = deadline = clock()
        for _ in range(cycles):
            missing = driver.counters["missing_replies"]
            t0 = clock()
            driver.read(t0 - start)
            status = driver.write(clock() - start)
            dt = clock() - t0
            if status is Status.ERROR:
                raise RuntimeError(f"the driver lost its bus: {driver.last_error}")
            times.append(dt)
            late = driver.counters["missing_replies"] > missing
            lost += late
            if period:
                misses += dt > period or late
                deadline += period
                if deadline < clock():
                    deadline = clock()  # skip, never catch up
                time.sleep(max(0.0, deadline - clock()))
        driver.deactivate()
    finally:
        driver.close()
    return times, misses, lost


def bench_virtual(joints: int = 6, cycles: int = 3000) -> dict:
    import can
    from drivers.can_joints import MitCanJointGroup
    from hil_sim.mit_drive import pump, stand_in_bus

    class LockStep(MitCanJointGroup):
        """The drives answer on the far end of the virtual bus right after each send (the
        lock-step simulator's turn in the tick)."""

        def _on_configure(self):
            self.peer = can.Bus(interface="virtual", channel=self.bus_options.kwargs["channel"])
            super()._on_configure()

        def _after_send(self):
            pump(drives, self.peer)

        def _on_close(self):
            super()._on_close()
            self.peer.shutdown()

    drives = stand_in_bus(range(1, joints + 1), timeout_s=10.0)
    driver = _driver({"interface": "virtual", "channel": f"bench-{uuid.uuid4()}"}, joints, None, LockStep)
    times, misses, lost = _paced(driver, cycles, None)
    return _stats("virtual (lock-step, in-process)", joints, times, misses, None, lost)


def _die_with_parent() -> None:
    """In the child: SIGTERM when the benchmark dies, so no server outlives it (Linux prctl)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _start_server(module: str, ids, extra=()) -> tuple[subprocess.Popen, dict]:
    proc = subprocess.Popen(
        [sys.executable, "-m", module, "--ids", *map(str, ids), *extra], stdout=subprocess.PIPE, text=True,
        preexec_fn=_die_with_parent,
    )
    ready, _, _ = select.select([proc.stdout], [], [], 20.0)
    if not ready:
        proc.kill()
        raise RuntimeError(f"{module} did not say where it listens within 20 s")
    return proc, json.loads(proc.stdout.readline())


def _stop(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def bench_socketcand(joints: int = 6, cycles: int = 3000, rate_hz: float = 1000.0) -> dict:
    proc, info = _start_server("hil_sim.socketcand", range(1, joints + 1))
    try:
        driver = _driver({"interface": "socketcand", "host": info["host"], "port": info["port"],
                          "channel": info["channels"][0], "tcp_tune": True}, joints, rate_hz)
        times, misses, lost = _paced(driver, cycles, rate_hz)
    finally:
        _stop(proc)
    return _stats("socketcand (drives in another process)", joints, times, misses, rate_hz, lost)


def bench_slcan(joints: int = 3, cycles: int = 3000, rate_hz: float = 1000.0) -> dict:
    proc, info = _start_server("hil_sim.slcan", range(1, joints + 1))
    try:
        driver = _driver({"interface": "slcan", "channel": info["tty"], "sleep_after_open": 0, "bitrate": 1_000_000,
                          "timeout": 0.0002},  # as configs/three_joint_slcan.toml: recv() blocks in steps of it
                         joints, rate_hz)
        times, misses, lost = _paced(driver, cycles, rate_hz)
    finally:
        _stop(proc)
    return _stats("slcan (drives in another process, pty)", joints, times, misses, rate_hz, lost)


def bench_can(cycles: int = 3000, rate_hz: float = 1000.0) -> dict:
    """Everything above; returns a JSON-able dict (see :func:`format_table`)."""
    from drivers.can_bus import PartialReads

    before = PartialReads.count
    cycles_ = [bench_virtual(6, cycles), bench_socketcand(6, cycles, rate_hz), bench_slcan(3, cycles, rate_hz)]
    return {"codec": bench_codec(), "cycles": cycles_, "goals": GOALS, "goals_met": _goals_met(cycles_),
            "socketcand_partial_reads": PartialReads.count - before}


def _goals_met(cycles: list) -> dict:
    sc = next(r for r in cycles if r["transport"].startswith("socketcand"))
    sl = next(r for r in cycles if r["transport"].startswith("slcan"))
    g = GOALS
    return {"socketcand": sc["median_ms"] <= g["socketcand"]["median_ms"] and sc["p99_ms"] <= g["socketcand"]["p99_ms"],
            "slcan": sl["misses"] <= g["slcan"]["misses"]}


def format_table(result: dict) -> str:
    c = result["codec"]
    lines = [
        "MIT codec (frames/s):",
        f"  pack_command_into {c['pack_per_s']:>12,.0f}   unpack_reply_into {c['unpack_per_s']:>12,.0f}"
        f"   both {c['pack_unpack_pairs_per_s']:>12,.0f}",
        "",
        "MitCanJointGroup.read() + write() per tick (collect the last tick's answers, send the commands):",
        f"{'transport':<42} {'joints':>6} {'rate':>6} {'cycles':>6} {'median ms':>9} {'p99 ms':>7} "
        f"{'max ms':>7} {'misses':>6} {'lost':>5}",
    ]
    for r in result["cycles"]:
        rate = f"{r['rate_hz']:g}" if r["rate_hz"] else "max"
        lines.append(
            f"{r['transport']:<42} {r['joints']:>6} {rate:>6} {r['cycles']:>6} {r['median_ms']:>9.3f} "
            f"{r['p99_ms']:>7.3f} {r['max_ms']:>7.3f} {r['misses']:>6} {r['lost']:>5}"
        )
    g = result["goals"]
    lines.append(
        f"goals: socketcand {g['socketcand']['joints']} joints read() + write() median ≤ {g['socketcand']['median_ms']} ms, "
        f"p99 ≤ {g['socketcand']['p99_ms']} ms; slcan {g['slcan']['joints']} joints at "
        f"{g['slcan']['rate_hz']} Hz with {g['slcan']['misses']} misses"
    )
    met = result.get("goals_met")
    if met is not None:
        lines.append("goals met: " + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in met.items())
                     + f"  (python-can's socketcand reads that ended mid-frame, waited out: "
                       f"{result['socketcand_partial_reads']})")
    return "\n".join(lines)
