"""``rtctl bench live``: what the Foxglove live view costs the loop — the shipped PUMA job (or
``--config``) on the embedded simulator, paced at ``rate`` on the wall clock with telemetry on,
without the live view and with it and one viewer subscribed to every channel, side by side.

The runs alternate (without, with, without, with …) so that a change in the machine's load
falls on both. The viewer is a process of its own (a Foxglove WebSocket client written with
``websockets``, never a thread of the loop's process); it counts the messages it receives.
Reported per run: wake lateness and tick compute p50/p99/max; per variant the median of the
runs' p99s, and the ratio with/without (the goal: within 1.10).
"""
from __future__ import annotations

import asyncio
import importlib.util
import json
import socket
import statistics
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from rtctl import logs
from rtctl.bench.loop import SHIPPED, _configured, _run
from rtctl.errors import RtctlError
from rtctl.telemetry.live_view import LiveConfig

PAIRS = 3
SUBPROTOCOL = "foxglove.sdk.v1"  # foxglove-sdk 0.30's name for the Foxglove WebSocket protocol


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def _view(port: int) -> dict:
    """Subscribe to every channel advertised and count until the server goes away."""
    import websockets

    for _ in range(600):  # the server is up once the daemon's start-up reaches it
        try:
            ws = await websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], max_size=None)
            break
        except OSError:
            await asyncio.sleep(0.05)
    else:
        return {"messages": 0, "bytes": 0, "channels": 0}
    counts = {"messages": 0, "bytes": 0, "channels": 0}
    try:
        async for frame in ws:
            if isinstance(frame, bytes):
                counts["messages"] += 1
                counts["bytes"] += len(frame)
                continue
            msg = json.loads(frame)
            if msg["op"] == "advertise":
                counts["channels"] += len(msg["channels"])
                await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                    {"id": c["id"], "channelId": c["id"]} for c in msg["channels"]]}))
    except websockets.ConnectionClosed:
        pass
    return counts


def _one(cfg, seconds: float, directory: Path, name: str, live: bool) -> dict:
    viewer = None
    if live:
        port = _free_port()
        cfg = replace(cfg, live=LiveConfig(port=port))
        viewer = subprocess.Popen([sys.executable, "-m", "rtctl.bench.live", str(port)], stdout=subprocess.PIPE,
                                  text=True)
    s = _run(cfg, seconds, directory, name)
    timing = s["timing"]
    out = {"live": live, "exit_code": s["exit_code"], "ticks": timing["ticks"], "overruns": timing["overruns"],
           "lateness_us": timing["wake_lateness_us"], "compute_us": timing["compute_us"]["tick"],
           "dropped_rows": s.get("telemetry", {}).get("dropped_rows")}
    if viewer is not None:
        out["viewer"] = json.loads(viewer.communicate(timeout=60)[0] or "{}")
    return out


def bench_live(config=None, rate: float = 1000.0, seconds: float = 10.0) -> dict:
    if importlib.util.find_spec("websockets") is None:
        raise RtctlError("`rtctl bench live` connects a viewer with the websockets package (in the `test` extra): "
                         "in the clone, .venv/bin/pip install -e '.[test]'")
    logs.configure("json", level="warning")
    cfg = _configured(config or SHIPPED, rate, True, 1.0)
    runs = []
    with tempfile.TemporaryDirectory(prefix="rtctl-bench-") as tmp:
        for k in range(PAIRS):
            for live in (False, True):
                runs.append(_one(cfg, seconds, Path(tmp), f"run{k}{'live' if live else ''}", live))
    result = {"config": str(cfg.file), "robot": cfg.model.name, "rate_hz": rate, "seconds": seconds, "runs": runs}
    for key in ("compute_us", "lateness_us"):
        without, with_live = ([statistics.median(r[key]["p99"] for r in runs if r["live"] is live)
                               for live in (False, True)])
        result[f"{key}_p99"] = {"without": without, "with_viewer": with_live, "ratio": with_live / without}
    return result


def format_table(result: dict) -> str:
    lines = [f"rtctl bench live — {result['robot']}, full stack paced at {result['rate_hz']:g} Hz, "
             f"{result['seconds']:g} s per run, telemetry on; live view off / on with one viewer on every channel",
             f"  {'run':<16} {'late p50':>9} {'late p99':>9} {'late max':>9} {'tick p50':>9} {'tick p99':>9} "
             f"{'tick max':>9} {'overruns':>8} {'viewer msgs/s':>14}"]
    for k, r in enumerate(result["runs"]):
        late, tick = r["lateness_us"], r["compute_us"]
        rate = r["viewer"]["messages"] / result["seconds"] if "viewer" in r else None
        lines.append(f"  {k // 2 + 1}: {'with viewer' if r['live'] else 'without':<13} {late['p50']:9.1f} "
                     f"{late['p99']:9.1f} {late['max']:9.1f} {tick['p50']:9.1f} {tick['p99']:9.1f} {tick['max']:9.1f} "
                     f"{r['overruns']:8d} {'-' if rate is None else f'{rate:.0f}':>14}")
    lines.append(f"  {'median of p99 (µs)':<22} {'without':>9} {'with':>9} {'ratio':>7}  (goal: ratio <= 1.10)")
    for key, label in (("compute_us_p99", "tick compute"), ("lateness_us_p99", "wake lateness")):
        p = result[key]
        lines.append(f"  {label:<22} {p['without']:9.1f} {p['with_viewer']:9.1f} {p['ratio']:7.3f}")
    return "\n".join(lines)


if __name__ == "__main__":  # the viewer: python -m rtctl.bench.live PORT → its counts as JSON
    print(json.dumps(asyncio.run(_view(int(sys.argv[1])))))
