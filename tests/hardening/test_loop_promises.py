"""Issue 25's promises about commands, checked through a running daemon: a storm of every
socket command from three clients delays no tick by a period (measured by the loop's own
lateness statistics), an e-stop acts at the next tick whatever is pending, ``reset`` re-enables
all devices or none, and nothing is accepted once the daemon is stopping."""
from __future__ import annotations

import itertools
import json
import socket
import struct
import threading
import time
from pathlib import Path

import msgpack
import pytest

from rtctl.control_socket import request
from runtime_helpers import ROOT
from stalls import VmStall
from test_io_devices import registry  # noqa: F401  (fixture)

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

RATE_HZ = 250.0  # one period (4 ms) is the bound; well above this VM's own wake-up jitter (≤ 2 ms idle)
A, B = [0, 45, -180, 0, 45, 0], [-30, 180, -60, 0, 30, 0]  # ready, place behind: the conveyor between
STORM = [  # every command, and the moves that used to stall the loop (planning up to a second)
    ("status", {}),
    ("move", {"waypoints": [B, A] * 10, "deg": True}),  # 20 waypoints, each leg around the conveyor
    ("move", {"q": A, "duration": 600.0, "deg": True}),  # a 600 s move: its guard check is long
    ("move", {"q": [0.0] * 5}),  # malformed: answered at once
    ("status", {}),
    ("estop", {}),
    ("move", {"q": B, "deg": True}),  # refused while e-stopped
    ("reset", {}),
    ("move", {"waypoints": [B, A, B], "deg": True}),
    ("bogus", {}),
]


def guard_config(tmp_path: Path) -> Path:
    text = (ROOT / "configs" / "puma560_guard_sim.toml").read_text()
    text = text.replace('description = "robots/puma560.toml"', f'description = "{ROOT}/configs/robots/puma560.toml"')
    text = text.replace("rate_hz = 1000.0", f"rate_hz = {RATE_HZ}").replace("overrun_limit = 50", "overrun_limit = 1000000")
    path = tmp_path / "guard.toml"
    path.write_text(text)
    return path


def client(path, seconds: float, offset: int, replies: list) -> None:
    end = time.monotonic() + seconds
    for cmd, fields in itertools.islice(itertools.cycle(STORM), offset, None):
        if time.monotonic() > end:
            return
        t0 = time.monotonic()
        reply = request(path, cmd, timeout=30.0, **fields)
        replies.append((cmd, reply, time.monotonic() - t0))


@pytest.mark.flaky(reruns=4, only_rerun=["VmStall"])
def test_defect_2_a_storm_of_every_command_from_3_clients_delays_no_tick_by_a_period(daemon, tmp_path):
    d = daemon(guard_config(tmp_path), "--duration", 60)
    d.wait_ready()
    time.sleep(1.0)
    replies: list = []
    clients = [threading.Thread(target=client, args=(d.socket, 6.0, 3 * i, replies)) for i in range(3)]
    for c in clients:
        c.start()
    for c in clients:
        c.join()
    # one move after the storm, waited for: on a loaded machine every move of the storm may be
    # cancelled (its e-stops) or still planning when it ends; the planner must still plan
    request(d.socket, "reset")
    replies.append(("move", request(d.socket, "move", timeout=60.0, q=A, deg=True), 0.0))
    request(d.socket, "stop")
    code, _, err = d.finish()
    summary = json.loads(d.summary.read_text())
    timing = summary["timing"]
    late, period_us = timing["wake_lateness_us"], timing["period_us"]
    by_cmd = {cmd: [r for c, r, _ in replies if c == cmd] for cmd, _ in STORM}
    seconds = {cmd: sorted(s for c, _, s in replies if c == cmd) for cmd, _ in STORM}
    print(f"\n{len(replies)} requests; wake lateness p99.9 {late['p99_9']:.0f} µs, max {late['max']:.0f} µs "
          f"(period {period_us:.0f} µs); e-stop answered in {1e3 * seconds['estop'][len(seconds['estop']) // 2]:.1f} "
          f"ms median, {1e3 * seconds['estop'][-1]:.1f} ms max; moves planned {sum(r['ok'] for r in by_cmd['move'])}, "
          f"busy {sum(bool(r.get('busy')) for r in by_cmd['move'])}")
    assert code in (0, 3), err[-3000:]  # 3: the last e-stop may still be latched
    assert all(isinstance(r["ok"], bool) and (r["ok"] or r["error"]) for _, r, _ in replies)
    assert any(r["ok"] for r in by_cmd["move"]) and any(r.get("busy") for r in by_cmd["move"])  # planned, and busy
    assert not [f for f in summary["safety"]["faults"] if f["kind"] != "estop"], summary["safety"]["faults"]
    serve = timing["compute_us"]["serve"]  # the loop's time in the control socket and the planner's pipe
    print(f"serving: p99.9 {serve['p99_9']:.0f} µs, max {serve['max']:.0f} µs; overruns {timing['overruns']}")
    # serving never costs a tick a period: p99.9 (the old code planned in ~5 % of the ticks, 0.3–1 s each); the
    # single worst tick is wall time a busy VM can stretch by preempting the loop, so it counts only on a quiet run
    stalled = timing["overruns"] or late["max"] >= period_us / 2  # the loop's own record of a stall
    if serve["p99_9"] >= period_us and not stalled:
        raise AssertionError(f"serving took {serve['p99_9']:.0f} µs in 1 tick of 1000")
    if serve["max"] >= period_us or late["max"] >= period_us:
        why = (f"serving took {serve['max']:.0f} µs in one tick (p99.9 {serve['p99_9']:.0f} µs), a wake-up was "
               f"{late['max']:.0f} µs late")
        if stalled:  # (serving time is wall time: a preempted loop serves slowly too)
            raise VmStall(f"{why}; {timing['overruns']} overruns")
        raise AssertionError(why)
    # the first e-stop latched in the tick that handled it (the stage acts on it at its next
    # check: tests/safety), whatever else was pending
    first = min(r["t"] for r in by_cmd["estop"])
    latched = min(e["t"] for e in summary["safety"]["events"] if e["event"] == "fault" and e["kind"] == "estop")
    assert first <= latched <= first + 1.0 / RATE_HZ + 1e-9, (first, latched)


def test_defect_7_a_move_sent_after_stop_is_refused(write_config, daemon):
    from runtime_helpers import BASE

    d = daemon(write_config(BASE), "--duration", 3600)  # (lock-step: 60 s of run can be gone in one wall second)
    d.wait_ready()
    frames = b"".join(struct.pack(">I", len(b)) + b for b in (msgpack.packb({"cmd": "stop"}),
                                                              msgpack.packb({"cmd": "move", "q": [0.1] * 6})))
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(10)
        s.connect(str(d.socket))
        s.sendall(frames)  # one connection: the move is served after the stop, while the robot stops
        replies = []
        for _ in range(2):
            (n,) = struct.unpack(">I", s.recv(4, socket.MSG_WAITALL))
            replies.append(msgpack.unpackb(s.recv(n, socket.MSG_WAITALL)))
    assert replies[0]["ok"] and replies[0]["stopping"]
    assert replies[1] == {"ok": False, "error": "move refused: the daemon is stopping (stop requested)"}
    assert d.finish()[0] == 0


def test_defect_5_reset_re_enables_all_devices_or_none(registry, write_config, tmp_path):
    """The joints' simulator comes back, the I/O device cannot: every device is put back in its
    safe state (the simulator's drives off again), the e-stop latched, and the reply names it."""
    from types import SimpleNamespace

    from rtctl.daemon import Daemon
    from rtctl.runtime import build
    from test_io_devices import config

    cfg = config(write_config, "activations = 1")  # bring-up's activation, then no more
    # lock-step runs ~60× real time: 30 s of run ended (a measured CI failure) between the e-stop
    # and the next poll for its verdict; the operator's `stop` ends this one
    args = SimpleNamespace(telemetry=None, socket=str(tmp_path / "s.sock"), enforce_rt=False, duration=3600.0,
                           summary=None, log_level="error")
    d = Daemon(cfg, build(cfg), args)
    seen = {}

    def operator():
        try:
            wait(lambda: request(args.socket, "status", timeout=5.0)["ok"])
            request(args.socket, "estop")
            wait(lambda: request(args.socket, "status")["verdict"] == "DEACTIVATE")
            seen["reset"] = request(args.socket, "reset")
            seen["lifecycles"] = {dev.name: dev.lifecycle.value for dev in d.rt.all_devices}
            seen["status"] = request(args.socket, "status")
        finally:
            request(args.socket, "stop")

    thread = threading.Thread(target=operator)
    thread.start()
    code = d.run()
    thread.join()
    reply = seen["reset"]
    assert reply["ok"] is False and "device eye could not be re-enabled" in reply["error"], reply
    assert "no answer to enable" in reply["error"]
    assert seen["lifecycles"] == {"sim": "inactive", "eye": "inactive"}, seen["lifecycles"]  # none left enabled
    assert seen["status"]["estopped"] and seen["status"]["verdict"] != "OK"
    assert code == 3


def wait(predicate, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if predicate():
                return
        except Exception:  # (the socket is not there yet)
            pass
        time.sleep(0.05)
    raise AssertionError("timed out")
