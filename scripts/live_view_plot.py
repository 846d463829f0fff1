#!/usr/bin/env python3
"""What a Foxglove viewer receives, drawn over the telemetry file of the same run:

    python scripts/live_view_plot.py docs/img/live_view_vs_telemetry.png [CONFIG]

Runs CONFIG (default: the shipped computed-torque PUMA job) for 4 s on the wall clock with
``--live`` on a free loopback port and ``--telemetry``; a Foxglove WebSocket client (the
``websockets`` package, a process of its own: this one) subscribes to /joint_states and
/joint_commands; then each joint's received positions (dots, every 40th) are drawn over the
file's rows (lines) against the loop's time, and the largest difference over every message
received is printed (0: the same numbers).
"""
from __future__ import annotations

import asyncio
import json
import socket
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SUBPROTOCOL = "foxglove.sdk.v1"  # foxglove-sdk 0.30's name for the Foxglove WebSocket protocol


async def receive(port: int, topics: tuple[str, ...]) -> dict:
    import websockets

    for _ in range(1200):
        try:
            ws = await websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], max_size=None)
            break
        except OSError:
            await asyncio.sleep(0.05)
    got = {topic: [] for topic in topics}
    ids = {}
    try:
        async for frame in ws:
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg["op"] == "advertise":
                    wanted = [c for c in msg["channels"] if c["topic"] in topics]
                    ids.update({c["id"]: c["topic"] for c in wanted})
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                        {"id": c["id"], "channelId": c["id"]} for c in wanted]}))
            elif frame[0] == 1:
                subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                got[ids[subscription]].append((log_time, json.loads(frame[13:])))
    except websockets.ConnectionClosed:
        pass
    return got


def main(argv: list[str]) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rtctl.telemetry import read

    out = Path(argv[0])
    config = argv[1] if len(argv) > 1 else str(ROOT / "configs" / "puma560_sim.toml")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with tempfile.TemporaryDirectory() as tmp:
        telemetry = Path(tmp) / "run.msgpack"
        daemon = subprocess.Popen([sys.executable, "-m", "rtctl.cli", "run", config, "--sim", "--duration", "4",
                                   "--live", str(port), "--telemetry", str(telemetry), "--socket",
                                   str(Path(tmp) / "s"), "--log-format", "json"], stdout=subprocess.DEVNULL, cwd=ROOT)
        got = asyncio.run(receive(port, ("/joint_states", "/joint_commands")))
        if daemon.wait() != 0:
            print(f"rtctl run exited {daemon.returncode}", file=sys.stderr)
            return 1
        tel = read(telemetry)
    row = {round(t * 1e9): k for k, t in enumerate(tel["t"])}
    states = got["/joint_states"]
    ks = np.array([row[ns] for ns, _ in states])
    received = np.array([m["position"] for _, m in states])
    names = states[0][1]["name"]
    fig, axes = plt.subplots(len(names), 1, sharex=True, figsize=(9, 1.6 * len(names)))
    for j, ax in enumerate(axes):
        ax.plot(tel["t"], tel["q"][:, j], lw=2.5, color="0.75", label="telemetry file q")
        ax.plot(tel["t"][ks][::40], received[::40, j], "o", ms=3, color="C0",
                label="received /joint_states.position (every 40th)")
        ax.set_ylabel(f"{names[j]}\n(rad)")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("loop time (s)")
    fig.suptitle(f"live view: {len(states)} messages received of {tel.rows} rows recorded; "
                 f"largest difference {np.abs(received - tel['q'][ks]).max():.1e} rad", fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"{len(states)} /joint_states and {len(got['/joint_commands'])} /joint_commands messages received, "
          f"{tel.rows} rows recorded; largest |received − recorded| = {np.abs(received - tel['q'][ks]).max():g} rad; "
          f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
