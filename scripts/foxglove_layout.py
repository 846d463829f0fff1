#!/usr/bin/env python3
"""Write configs/foxglove/puma_layout.json, the Foxglove layout for the PUMA 560 jobs:

    python scripts/foxglove_layout.py            # (re)writes the shipped file
    python scripts/foxglove_layout.py OUT.json   # or writes it elsewhere

One layout for a live robot (`rtctl run … --live`) and a recorded run (`rtctl export … --mcap`),
since both carry the same channels (rtctl/telemetry/channels.py). Tabs: tracking (joint
positions and their references, torques, the event log), controller (which are active — the
switch job has two —, computed torque's q̈ command, C* Slotine–Li's s and first estimates), timing (the tick's phases) and marker (the
vision job's pixels). A panel whose topic a job does not publish stays empty. Every series is
plotted against the message's time (its log time in a file, its time in a live frame): the
loop's time since the start of the run. The file is Foxglove's layout export format (Layout →
Import from file).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "configs" / "foxglove" / "puma_layout.json"
JOINTS = ("waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange")
PHASES = ("read", "update", "safety", "write", "record", "serve")  # rtctl.timing.DAEMON_PHASES


def plot(title: str, series: list[tuple[str, str]]) -> dict:
    return {"title": title, "paths": [{"value": path, "label": label, "enabled": True, "timestampMethod": "receiveTime"}
                                      for path, label in series],
            "showXAxisLabels": True, "showYAxisLabels": True, "showLegend": True, "legendDisplay": "floating",
            "isSynced": True, "xAxisVal": "timestamp", "followingViewWidth": 10}


def per_joint(topic: str, field: str, suffix: str = "") -> list[tuple[str, str]]:
    return [(f"{topic}.{field}[{j}]", f"{name}{suffix}") for j, name in enumerate(JOINTS)]


def split(first: str, second: str, direction: str = "column", percentage: float = 50) -> dict:
    return {"first": first, "second": second, "direction": direction, "splitPercentage": percentage}


def layout() -> dict:
    panels = {
        "Plot!positions": plot("joint position and reference (rad)", per_joint("/joint_states", "position")
                               + per_joint("/joint_commands", "position", " ref")),
        "Plot!torques": plot("torque command (N·m)", per_joint("/joint_commands", "effort")),
        "Log!events": {"searchTerms": [], "minLogLevel": 1, "topicToRender": "/events"},
        "Plot!qdd": plot("computed torque: q̈ command (rad/s²)", per_joint("/controller/qdd_cmd", "data")),
        "Plot!s": plot("C* Slotine–Li: s = q̇ − q̇_r (rad/s)", per_joint("/controller/s", "data")),
        "Plot!active": plot("controllers active (1: on; in the configuration's order)",
                            [(f"/controller/controllers_active.data[{k}]", f"controller {k + 1}") for k in range(2)]),
        "Plot!estimates": plot("C* Slotine–Li: first estimates π̂", [(f"/controller/params_hat.data[{k}]", f"π̂[{k}]")
                                                                     for k in range(10)]),
        "Plot!timing": plot("tick phases (µs)", [(f"/timing.{p}_us", p) for p in PHASES]),
        "Plot!marker": plot("marker (px)", [("/controller/marker_measured_px.data[0]", "measured u"),
                                            ("/controller/marker_measured_px.data[1]", "measured v"),
                                            ("/controller/marker_predicted_px.data[0]", "predicted u"),
                                            ("/controller/marker_predicted_px.data[1]", "predicted v")]),
        "Plot!marker_error": plot("marker error (px)", [("/controller/marker_error_px.data[0]", "u"),
                                                        ("/controller/marker_error_px.data[1]", "v")]),
    }
    panels["Tab!rtctl"] = {"activeTabIdx": 0, "tabs": [
        {"title": "Tracking", "layout": split(split("Plot!positions", "Plot!torques"), "Log!events", "column", 75)},
        {"title": "Controller", "layout": split(split("Plot!active", "Plot!qdd", "column", 30),
                                                split("Plot!s", "Plot!estimates"), "column", 45)},
        {"title": "Timing", "layout": "Plot!timing"},
        {"title": "Marker", "layout": split("Plot!marker", "Plot!marker_error")},
    ]}
    return {"configById": panels, "globalVariables": {}, "userNodes": {}, "playbackConfig": {"speed": 1},
            "layout": "Tab!rtctl"}


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else OUT
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(layout(), indent=2, ensure_ascii=False) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
