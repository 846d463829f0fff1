"""Run configurations with interference zones, a run through ``rtctl`` with the test
controllers registered, and the checks every closed-loop guard test makes."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from rtctl.config import load_config
from rtctl.guard.kernels import clearances
from rtctl.telemetry import read

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
PUMA = ROOT / "configs" / "robots" / "puma560.toml"
# the shipped cell's overhead conveyor (configs/puma560_guard_sim.toml), shoulder–elbow plane, degrees
CONVEYOR = ("[[124, -181], [80, -149], [68, -135], [24, -48], [21, -11], [40, 8], [77, -4], [127, -62], "
            "[160, -143], [160, -148], [152, -177]]")
READY = "[0.0, 0.7854, -3.1416, 0.0, 0.7854, 0.0]"


def guard_section(action="stop", guard_margin=0.5, deceleration=1000.0) -> str:
    return f"""
[guard]
unit = "deg"
guard_margin = {guard_margin}
action = "{action}"
deceleration = {deceleration}

[[guard.zones]]
name = "overhead_conveyor"
joints = ["shoulder", "elbow"]
polygon = {CONVEYOR}
"""


def step_controller(target, kp=(400.0, 400.0, 400.0, 50.0, 50.0, 50.0), kd=(40.0, 40.0, 40.0, 5.0, 5.0, 5.0),
                    at=0.2) -> str:
    return f"""
[[controllers]]
name = "step"
type = "step_into"
kp = {list(kp)}
kd = {list(kd)}
target = {list(map(float, target))}
at = {at}
"""


def sim_config(controller: str, guard: str, initial_q: str = READY) -> str:
    return f"""
[robot]
description = "{PUMA}"

[loop]
rate_hz = 1000.0
realtime_factor = 0.0

[sim]
substeps = 4
initial_q = {initial_q}

[safety]
fallback = "hold"
damping = 40.0
hold_stiffness = 400.0
fault_off_delay = 1.0
{controller}{guard}"""


def rtctl(*args, timeout=120, env=None):
    """``rtctl ARGS…`` as a user runs it (with the test controllers registered): CompletedProcess."""
    return subprocess.run([sys.executable, str(HERE / "rtctl_with_test_controllers.py"), *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT, env=env)


def rtctl_run(config, tmp_path, *extra, env=None, timeout=180):
    """``rtctl run CONFIG`` with the step controller registered: (returncode, summary, telemetry, stderr)."""
    telemetry, summary = tmp_path / "run.msgpack", tmp_path / "summary.json"
    result = subprocess.run([sys.executable, str(HERE / "rtctl_with_test_controllers.py"), "run", str(config),
                             "--telemetry", str(telemetry), "--summary", str(summary), "--socket",
                             str(tmp_path / "rtctl.sock"), *map(str, extra)],
                            capture_output=True, text=True, timeout=timeout, cwd=ROOT, env=env)
    assert summary.exists(), result.stderr[-3000:]
    return result.returncode, json.loads(summary.read_text()), read(telemetry), result.stderr


def depths(config, q) -> np.ndarray:
    """Per row of ``q``: the signed distance to the nearest zone of ``config`` (< 0: inside)."""
    scene = load_config(config).guard.scene
    out = np.empty(len(q))
    clearances(*scene.tables(), np.ascontiguousarray(q, dtype=float), out)
    return out


def guard_events(summary) -> list[dict]:
    return [e for e in summary["safety"]["events"] if e["event"] == "guard"]


def travel_after(telemetry, event) -> tuple[float, float]:
    """(largest distance from the event's position reached afterwards, the predicted stopping distance)."""
    q_event = np.array(event["q"])
    after = telemetry["q"][telemetry["t"] >= event["t"]]
    return float(np.linalg.norm(after - q_event, axis=1).max()), float(np.linalg.norm(np.array(event["stop_point"]) - q_event))
