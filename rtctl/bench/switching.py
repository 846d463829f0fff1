"""``rtctl bench switching``: what live operation costs the loop — the same paced run of
configs/puma560_switch_sim.toml (computed torque active, C* Slotine–Li inactive) three times,
side by side: untouched; with 10 controller switches per second (ct ↔ adaptive, estimates kept);
with 10 gain sets per second (``ct.kp`` and ``adaptive.kd`` alternately). The requests come from
a separate process over the control socket, as an operator's would (no thread in the loop's
process). Reports wake lateness and the tick's compute percentiles of each run, and the requests'
round trips.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from rtctl import logs
from rtctl.bench.loop import CONFIGS, KNOBS, _run
from rtctl.config import load_config

SWITCH_CONFIG = CONFIGS / "puma560_switch_sim.toml"
PER_SECOND = 10

# the operator, in its own process: a request every 1/PER_SECOND s once the loop answers, round trips to stdout
_CLIENT = r"""
import json, socket, struct, sys, time
import msgpack
path, kind, per_second, seconds = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
def ask(request):
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(5.0)
        s.connect(path)
        body = msgpack.packb(request)
        s.sendall(struct.pack(">I", len(body)) + body)
        head = s.recv(4)
        n = struct.unpack(">I", head)[0]
        data = b""
        while len(data) < n:
            data += s.recv(n - len(data))
        return msgpack.unpackb(data)
while True:  # until the loop runs: while the daemon starts, status answers ok: false
    try:
        if ask({"cmd": "status"}).get("ok"):
            break
    except OSError:
        pass
    time.sleep(0.01)
requests = [{"cmd": "switch", "activate": ["adaptive"], "estimates": "keep"},
            {"cmd": "switch", "activate": ["ct"], "estimates": "keep"}] if kind == "switch" else \
           [{"cmd": "set", "key": "ct.kp", "value": 400.0}, {"cmd": "set", "key": "adaptive.kd", "value": 40.0}]
rtt, ok, start = [], 0, time.monotonic()
k = 0
while time.monotonic() - start < seconds - 1.0:
    a = time.perf_counter()
    try:
        ok += bool(ask(requests[k % 2]).get("ok"))
    except OSError:
        break
    rtt.append((time.perf_counter() - a) * 1e3)
    k += 1
    time.sleep(max(0.0, start + k / per_second - time.monotonic()))
print(json.dumps({"requests": len(rtt), "ok": ok, "rtt_ms": sorted(rtt)}))
"""


def _paced(cfg, seconds: float, directory: Path, kind: str | None) -> dict:
    client = None
    if kind is not None:
        socket_path = directory / f"{kind}.sock"
        client = subprocess.Popen([sys.executable, "-c", _CLIENT, str(socket_path), kind, str(PER_SECOND), str(seconds)],
                                  stdout=subprocess.PIPE, text=True)
    s = _run(cfg, seconds, directory, kind or "untouched")
    out = {"timing": s["timing"], "exit_code": s["exit_code"], "events": len(s.get("operator", {}).get("events", []))}
    if client is not None:
        reply = json.loads(client.communicate(timeout=60)[0] or "{}")
        rtt = reply.get("rtt_ms") or [float("nan")]
        out["client"] = {"requests": reply.get("requests", 0), "ok": reply.get("ok", 0),
                         "rtt_ms_p50": rtt[len(rtt) // 2], "rtt_ms_max": rtt[-1]}
    return out


def bench_switching(seconds: float = 10.0) -> dict:
    logs.configure("json", level="warning")
    from dataclasses import replace

    cfg = load_config(SWITCH_CONFIG, sim=True)
    cfg = replace(cfg, loop=replace(cfg.loop, rt=KNOBS), telemetry_path=None)
    result = {"config": str(cfg.file), "rate_hz": cfg.loop.rate_hz, "seconds": seconds, "per_second": PER_SECOND}
    with tempfile.TemporaryDirectory(prefix="rtctl-bench-") as tmp:
        for kind in (None, "switch", "set"):
            result[kind or "untouched"] = _paced(cfg, seconds, Path(tmp), kind)
    return result


def format_table(result: dict) -> str:
    runs = ("untouched", "switch", "set")
    lines = [f"rtctl bench switching — {Path(result['config']).name}, paced at {result['rate_hz']:g} Hz for "
             f"{result['seconds']:g} s each; {result['per_second']} requests/s from another process",
             f"  {'(µs)':<26} " + " ".join(f"{r:>14}" for r in runs)]

    def row(name, get):
        values = []
        for r in runs:
            try:
                values.append(f"{get(result[r]):14.1f}")
            except (KeyError, TypeError):
                values.append(f"{'-':>14}")
        lines.append(f"  {name:<26} " + " ".join(values))

    row("wake lateness p50", lambda r: r["timing"]["wake_lateness_us"]["p50"])
    row("wake lateness p99", lambda r: r["timing"]["wake_lateness_us"]["p99"])
    row("compute: tick p50", lambda r: r["timing"]["compute_us"]["tick"]["p50"])
    row("compute: tick p99", lambda r: r["timing"]["compute_us"]["tick"]["p99"])
    row("compute: update p99", lambda r: r["timing"]["compute_us"]["update"]["p99"])
    row("compute: serve p99", lambda r: r["timing"]["compute_us"]["serve"]["p99"])
    row("compute: serve max", lambda r: r["timing"]["compute_us"]["serve"]["max"])
    row("compute: tick max", lambda r: r["timing"]["compute_us"]["tick"]["max"])
    row("overruns", lambda r: r["timing"]["overruns"])
    row("changes recorded", lambda r: r["events"])
    row("request round trip p50 (ms)", lambda r: r["client"]["rtt_ms_p50"])
    row("request round trip max (ms)", lambda r: r["client"]["rtt_ms_max"])
    base = result["untouched"]["timing"]
    for r in ("switch", "set"):
        t = result[r]["timing"]
        lines.append(f"  {r}: compute p99 ×{t['compute_us']['tick']['p99'] / base['compute_us']['tick']['p99']:.2f}, "
                     f"lateness p99 ×{t['wake_lateness_us']['p99'] / base['wake_lateness_us']['p99']:.2f} "
                     f"of the untouched run; exit code {result[r]['exit_code']}")
    lines.append("  (a request is served in 1 % of the ticks: the p99 is that tick's; while switched, half of the "
                 "time the update is C* Slotine–Li's, dearer than computed torque's)")
    return "\n".join(lines)
