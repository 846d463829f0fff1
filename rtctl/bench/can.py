"""``rtctl bench can``: the MIT codec's frames per second, and the command/reply cycle of a
joint group over each CAN transport, as the CAN driver would run it every tick.

* codec: ``pack_command_into`` (one command into a reused buffer), ``unpack_reply_into``
  (one reply into a preallocated row), and the two together;
* cycle: send one command per joint, wait for every reply; over ``virtual`` in lock-step in
  this process (the embedded simulator's path), and over ``socketcand`` (6 joints) and
  ``slcan`` (3 joints: python-can reads slcan one byte per call) with the drives in their own
  process (``python -m hil_sim.socketcand|slcan``), as in HIL. Paced at ``rate_hz`` with
  absolute deadlines; a cycle longer than the period is a miss.

Goals: socketcand 6-joint cycle median ≤ 0.35 ms, p99 ≤ 0.7 ms;
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


class _Cycle:
    """The master side: preallocated messages, replies decoded into a preallocated array."""

    def __init__(self, bus, ids):
        import can
        from drivers.protocols import mit

        self.mit, self.bus, self.model = mit, bus, mit.KATZ
        self.messages = [can.Message(arbitration_id=i, data=bytearray(8), is_extended_id=False) for i in ids]
        self.rows = {i: k for k, i in enumerate(ids)}
        self.state = np.zeros((len(ids), mit.REPLY_COLUMNS))

    def enter(self, after_send=None) -> None:
        for m in self.messages:
            m.data[:] = self.mit.special_frame(self.mit.Special.ENTER_MOTOR_MODE)
        if not self.run(0, timeout=2.0, after_send=after_send):
            raise RuntimeError("the drives did not answer ENTER_MOTOR_MODE")

    def run(self, k, timeout=0.1, after_send=None, spin=False) -> bool:
        """One cycle; ``spin`` polls ``recv(0)`` instead of blocking in ``recv(timeout)``, as a
        loop that spins to its deadline would (on a VM a halted vCPU wakes up slowly)."""
        mit = self.mit
        for row, m in enumerate(self.messages):
            if k:
                mit.pack_command_into(m.data, self.model, 0.1 * row, 0.0, 10.0, 0.5, 0.0)
            self.bus.send(m)
        if after_send is not None:
            after_send()
        got, deadline = 0, time.perf_counter() + timeout
        while got < len(self.messages):
            msg = self.bus.recv(0.0 if spin else max(0.0, deadline - time.perf_counter()))
            if msg is None:
                if spin and time.perf_counter() < deadline:
                    continue
                return False
            row = self.rows.get(mit.reply_drive_id(msg.data, self.model))
            if row is not None:
                mit.unpack_reply_into(msg.data, self.model, self.state, row)
                got += 1
        return True


def _stats(transport, joints, times_s, misses, rate_hz, failures=0, spin=False) -> dict:
    ms = np.asarray(times_s) * 1e3
    return {"transport": transport, "joints": joints, "cycles": len(ms), "rate_hz": rate_hz,
            "wait": "spin" if spin else "block",
            "median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max()), "misses": misses, "lost": failures}


def _paced(cycle: _Cycle, cycles: int, rate_hz: float | None, after_send=None, spin=False):
    """Run ``cycles`` cycles, paced at ``rate_hz`` with absolute deadlines (None: back to back);
    a cycle longer than the period is a miss, one without all replies within 0.1 s is lost."""
    period = 1.0 / rate_hz if rate_hz else 0.0
    times, misses, lost = [], 0, 0
    clock = time.perf_counter
    deadline = clock()
    for k in range(1, cycles + 1):
        t0 = clock()
        ok = cycle.run(k, after_send=after_send, spin=spin)
        dt = clock() - t0
        lost += not ok
        times.append(dt)
        if period:
            misses += dt > period or not ok
            deadline += period
            if deadline < clock():
                deadline = clock()  # skip, never catch up
            time.sleep(max(0.0, deadline - clock()))
    return times, misses, lost


def bench_virtual(joints: int = 6, cycles: int = 3000) -> dict:
    import can
    from hil_sim.mit_drive import pump, stand_in_bus

    channel = f"bench-{uuid.uuid4()}"
    master, peer = can.Bus(interface="virtual", channel=channel), can.Bus(interface="virtual", channel=channel)
    drives = stand_in_bus(range(1, joints + 1), timeout_s=10.0)
    try:
        cycle = _Cycle(master, list(range(1, joints + 1)))
        step = lambda: pump(drives, peer)  # noqa: E731 — the lock-step simulator's turn in the tick
        cycle.enter(after_send=step)
        times, misses, lost = _paced(cycle, cycles, None, after_send=step)
    finally:
        master.shutdown()
        peer.shutdown()
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


def bench_socketcand(joints: int = 6, cycles: int = 3000, rate_hz: float = 1000.0, spin: bool = False) -> dict:
    import can

    ids = list(range(1, joints + 1))
    proc, info = _start_server("hil_sim.socketcand", ids)
    try:
        bus = can.Bus(interface="socketcand", host=info["host"], port=info["port"], channel=info["channels"][0],
                      tcp_tune=True)
        try:
            cycle = _Cycle(bus, ids)
            cycle.enter()
            times, misses, lost = _paced(cycle, cycles, rate_hz, spin=spin)
        finally:
            bus.shutdown()
    finally:
        _stop(proc)
    return _stats("socketcand (drives in another process)", joints, times, misses, rate_hz, lost, spin)


def bench_slcan(joints: int = 3, cycles: int = 3000, rate_hz: float = 1000.0, spin: bool = False) -> dict:
    import can

    ids = list(range(1, joints + 1))
    proc, info = _start_server("hil_sim.slcan", ids)
    try:
        bus = can.Bus(interface="slcan", channel=info["tty"], sleep_after_open=0, bitrate=1_000_000)
        try:
            cycle = _Cycle(bus, ids)
            cycle.enter()
            times, misses, lost = _paced(cycle, cycles, rate_hz, spin=spin)
        finally:
            bus.shutdown()
    finally:
        _stop(proc)
    return _stats("slcan (drives in another process, pty)", joints, times, misses, rate_hz, lost, spin)


def bench_can(cycles: int = 3000, rate_hz: float = 1000.0) -> dict:
    """Everything above; returns a JSON-able dict (see :func:`format_table`)."""
    return {
        "codec": bench_codec(),
        "cycles": [
            bench_virtual(6, cycles),
            *(bench_socketcand(6, cycles, rate_hz, spin) for spin in (False, True)),
            *(bench_slcan(3, cycles, rate_hz, spin) for spin in (False, True)),
        ],
        "goals": GOALS,
    }


def format_table(result: dict) -> str:
    c = result["codec"]
    lines = [
        "MIT codec (frames/s):",
        f"  pack_command_into {c['pack_per_s']:>12,.0f}   unpack_reply_into {c['unpack_per_s']:>12,.0f}"
        f"   both {c['pack_unpack_pairs_per_s']:>12,.0f}",
        "",
        f"{'command/reply cycle':<42} {'wait':>5} {'joints':>6} {'rate':>6} {'cycles':>6} {'median ms':>9} {'p99 ms':>7} "
        f"{'max ms':>7} {'misses':>6} {'lost':>5}",
    ]
    for r in result["cycles"]:
        rate = f"{r['rate_hz']:g}" if r["rate_hz"] else "max"
        lines.append(
            f"{r['transport']:<42} {r['wait']:>5} {r['joints']:>6} {rate:>6} {r['cycles']:>6} {r['median_ms']:>9.3f} "
            f"{r['p99_ms']:>7.3f} {r['max_ms']:>7.3f} {r['misses']:>6} {r['lost']:>5}"
        )
    g = result["goals"]
    lines.append(
        f"goals: socketcand {g['socketcand']['joints']} joints median ≤ {g['socketcand']['median_ms']} ms, "
        f"p99 ≤ {g['socketcand']['p99_ms']} ms; slcan {g['slcan']['joints']} joints at "
        f"{g['slcan']['rate_hz']} Hz with {g['slcan']['misses']} misses"
    )
    return "\n".join(lines)
