"""``rtctl bench plants``: one loop period of each simulated plant on the PUMA 560 (1 ms, 4 substeps,
a torque held) — rtctl's rigid-body plant (one compiled call) and MuJoCo (``mj_step``, the `mujoco`
extra), each with Euler and RK4 — as the median µs per period and the plant's own real-time factor
(what the plant alone would allow; a lock-step run adds the controller, safety stage and telemetry).
"""
from __future__ import annotations

import time

import numpy as np

from hil_sim.plant import Plant
from rtctl.model import load_robot

PERIOD, SUBSTEPS = 1e-3, 4


def _median_us(plant, periods: int) -> float:
    rng = np.random.default_rng(0)
    plant.tau_cmd[:] = rng.uniform(-5, 5, len(plant.tau_cmd))
    for _ in range(20):  # (compiled, cached)
        plant.step(PERIOD)
    samples = []
    for _ in range(periods):
        t0 = time.perf_counter_ns()
        plant.step(PERIOD)
        samples.append(time.perf_counter_ns() - t0)
    return float(np.median(samples)) / 1e3


def bench_plants(robot_path, periods: int = 3000) -> dict:
    model = load_robot(robot_path)
    q0 = np.clip(np.zeros(model.nq), model.q_min, model.q_max)
    rows = []
    for integrator in ("euler", "rk4"):
        plant = Plant(model, substeps=SUBSTEPS, integrator=integrator, q0=q0)
        rows.append({"engine": "rigid", "integrator": integrator, "us_per_period": _median_us(plant, periods)})
    try:
        from hil_sim.mujoco_plant import MujocoPlant

        for integrator in ("euler", "rk4"):
            plant = MujocoPlant(model, period=PERIOD, substeps=SUBSTEPS, integrator=integrator, q0=q0)
            rows.append({"engine": "mujoco", "integrator": integrator, "us_per_period": _median_us(plant, periods)})
    except ImportError as e:
        rows.append({"engine": "mujoco", "integrator": "-", "us_per_period": None, "note": str(e)})
    for r in rows:
        r["plant_realtime_factor"] = PERIOD * 1e6 / r["us_per_period"] if r["us_per_period"] else None
    return {"robot": model.name, "joints": model.nq, "period_s": PERIOD, "substeps": SUBSTEPS, "rows": rows}


def format_table(result: dict) -> str:
    lines = [f"rtctl bench plants — {result['robot']} ({result['joints']} joints), one {result['period_s'] * 1e3:g} ms "
             f"period of {result['substeps']} substeps, median",
             f"  {'engine':<8} {'integrator':<10} {'µs/period':>10} {'× real time':>12}"]
    for r in result["rows"]:
        if r["us_per_period"] is None:
            lines.append(f"  {r['engine']:<8} {'-':<10} {'-':>10} {'-':>12}  ({r['note']})")
        else:
            lines.append(f"  {r['engine']:<8} {r['integrator']:<10} {r['us_per_period']:10.1f} "
                         f"{r['plant_realtime_factor']:12.0f}")
    return "\n".join(lines)
