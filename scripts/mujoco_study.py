#!/usr/bin/env python3
"""The controllers against two plants — rtctl's own and MuJoCo — and a payload only MuJoCo has
(docs/mujoco.md):

    python scripts/mujoco_study.py table       # the PUMA jobs, embedded plant vs MuJoCo
    python scripts/mujoco_study.py payload     # 2 kg at the flange: computed torque vs C* Slotine–Li
    python scripts/mujoco_study.py all --out docs

Each case is a shipped configuration run in-process as `rtctl run` runs it, lock-step (as fast as
possible: the numbers do not depend on the machine), with ``[sim] engine`` (and ``payload``) set.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hil_sim.payload import Payload, fold_payload  # noqa: E402
from rtctl import logs  # noqa: E402
from rtctl.config import load_config  # noqa: E402
from rtctl.jsonout import dumps  # noqa: E402
from rtctl.tomltable import Table  # noqa: E402

CONFIGS = ROOT / "configs"
JOBS = {  # name → (configuration, seconds, controller replaced or None)
    "computed torque (true model)": ("puma560_sim.toml", 6.0, None),
    "C* Slotine–Li (π̂(0) = 0)": ("puma560_cstar_sim.toml", 10.0, None),
    "PD + gravity": ("puma560_sim.toml", 6.0, {"type": "pd_gravity", "kp": [900.0, 1600.0, 600.0, 60.0, 60.0, 40.0],
                                                "kd": [90.0, 160.0, 60.0, 6.0, 6.0, 4.0]}),
    "ARMA/GMV (3-joint PUMA)": ("puma3_arma_gmv_sim.toml", 3.0, None),
    "guard scene (computed torque)": ("puma560_guard_sim.toml", 8.0, None),
}
PAYLOAD = Payload(2.0, np.array([0.0, 0.0, 0.05]), np.array([0.002, 0.002, 0.001, 0.0, 0.0, 0.0]))


def run(config: str, seconds: float, engine: str, payload: Payload | None = None, controller: dict | None = None,
        telemetry: bool = False) -> dict:
    from rtctl.daemon import Daemon
    from rtctl.runtime import build

    cfg = load_config(CONFIGS / config, sim=True)
    sim = dict(cfg.sim.data, engine=engine)
    if payload is not None:
        sim["payload"] = {"mass": payload.mass, "com": payload.com.tolist(), "inertia": payload.inertia.tolist()}
    cfg = replace(cfg, sim=Table(sim, cfg.file, "sim"), loop=replace(cfg.loop, realtime_factor=0.0))
    if controller is not None:
        first = cfg.controllers[0]
        data = {k: v for k, v in controller.items() if k != "type"}
        cfg = replace(cfg, controllers=(replace(first, type=controller["type"], options=Table(data, cfg.file,
                                                                                                "controllers[0]")),))
    with tempfile.TemporaryDirectory(prefix="rtctl-mujoco-") as tmp:
        args = SimpleNamespace(telemetry=str(Path(tmp) / "run.msgpack") if telemetry else None,
                               socket=str(Path(tmp) / "s.sock"), summary=str(Path(tmp) / "s.json"), duration=seconds,
                               enforce_rt=False)
        code = Daemon(cfg, build(cfg), args).run()
        summary = json.loads(Path(args.summary).read_text())
        if telemetry:
            from rtctl.telemetry import read

            summary["telemetry_data"] = read(args.telemetry)
    e = summary.get("tracking_error_rad") or {}
    return {"exit_code": code, "faults": summary["safety"]["faults"],
            "rms_deg": np.degrees(e.get("rms_all", np.nan)), "max_deg": np.degrees(e.get("max_all", np.nan)),
            "realtime_ratio": summary["timing"]["realtime_ratio"], "telemetry": summary.get("telemetry_data")}


def table(out: Path) -> list[dict]:
    rows = []
    for name, (config, seconds, controller) in JOBS.items():
        row = {"job": name, "config": config, "seconds": seconds}
        for engine in ("rigid", "mujoco"):
            r = run(config, seconds, engine, controller=controller)
            row[engine] = {k: v for k, v in r.items() if k != "telemetry"}
        rows.append(row)
    lines = ["| job | plant | RMS error (°) | max error (°) | × real time | faults |", "|---|---|---|---|---|---|"]
    for row in rows:
        for engine, label in (("rigid", "embedded"), ("mujoco", "MuJoCo")):
            r = row[engine]
            lines.append(f"| {row['job']} | {label} | {r['rms_deg']:.4f} | {r['max_deg']:.4f} | {r['realtime_ratio']:.1f} | "
                         f"{len(r['faults']) or 'none'} |")
    _write(out, "mujoco_controllers", rows, lines)
    return rows


def payload(out: Path) -> dict:
    """2 kg at the flange, only in MuJoCo: computed torque keeps its nominal model; C* Slotine–Li,
    from the nominal model (π̂(0) = π), adapts — and π̂ of the last link is compared with the
    last link plus the payload."""
    result = {"payload": {"mass": PAYLOAD.mass, "com": PAYLOAD.com.tolist(), "inertia": PAYLOAD.inertia.tolist()}}
    for name, config, seconds in (("computed torque", "puma560_sim.toml", 10.0),
                                  ("C* Slotine–Li", "puma560_cstar_sim.toml", 20.0)):
        for with_payload in (False, True):
            r = run(config, seconds, "mujoco", PAYLOAD if with_payload else None, telemetry=True)
            tel = r.pop("telemetry")
            key = f"{name}, {'with' if with_payload else 'without'} payload"
            result[key] = r
            if "params_hat" in tel and with_payload:
                cfg = load_config(CONFIGS / config, sim=True)
                truth = fold_payload(cfg.model, PAYLOAD).params[-1]
                hat = tel["params_hat"][-1].reshape(-1, 10)[-1]
                t = tel["t"]
                e = np.abs(tel["q"] - tel["q_des"])
                result[key].update({"pi_last_hat": hat.tolist(), "pi_last_true_with_payload": truth.tolist(),
                                    "pi_last_nominal": cfg.model.params[-1].tolist(),
                                    "max_error_last_5s_deg": float(np.degrees(e[t > t[-1] - 5].max()))})
    lines = [f"payload {PAYLOAD.mass} kg at the flange, in MuJoCo only",
             "| controller | payload | RMS error (°) | max error (°) |", "|---|---|---|---|"]
    for key, r in result.items():
        if key != "payload":
            name, _, which = key.partition(", ")
            lines.append(f"| {name} | {which} | {r['rms_deg']:.4f} | {r['max_deg']:.4f} |")
    _write(out, "mujoco_payload", result, lines)
    return result


def _write(out: Path, name: str, data, lines) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.json").write_text(dumps(data, indent=1, default=str))
    print("\n".join(lines) + "\n", flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("what", choices=("table", "payload", "all"))
    p.add_argument("--out", type=Path, default=Path("out/mujoco"), help="directory for the JSON (default out/mujoco)")
    args = p.parse_args(argv)
    logs.configure("json", level="error")
    if args.what in ("table", "all"):
        table(args.out)
    if args.what in ("payload", "all"):
        payload(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
