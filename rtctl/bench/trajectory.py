"""``rtctl bench trajectory``: sampling a joint trajectory every tick, and planning one.

``sample()`` per call on a smooth 6-joint trajectory through random waypoints (per-call
``perf_counter_ns``, its own ~0.1 µs included); planning times of ``through_waypoints``
(stopping and smooth) and of a mid-motion ``retarget`` (what a ``move`` request costs the
tick in which it arrives).
"""
from __future__ import annotations

import time

import numpy as np

from rtctl.bench import percentiles_us
from rtctl.trajectory import JointLimits, retarget, through_waypoints


def bench_trajectory(n: int = 6, samples: int = 20000, plans: int = 50, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    lim = JointLimits(np.full(n, 2.0), np.full(n, 5.0), np.full(n, -3.0), np.full(n, 3.0))
    waypoints = rng.uniform(-2.0, 2.0, (5, n))
    traj = through_waypoints(waypoints, lim, smooth=True)
    q, qd, qdd = np.zeros(n), np.zeros(n), np.zeros(n)
    ts = np.linspace(traj.t_start, traj.t_end, samples).tolist()
    traj.sample(ts[0], q, qd, qdd)
    ns = np.zeros(samples, np.int64)
    clock = time.perf_counter_ns
    for k, t in enumerate(ts):
        a = clock()
        traj.sample(t, q, qd, qdd)
        ns[k] = clock() - a
    plan_ns = {"through_waypoints stop": [], "through_waypoints smooth": [], "retarget mid-motion": []}
    for _ in range(plans):
        wp = rng.uniform(-2.0, 2.0, (4, n))
        for smooth, key in ((False, "through_waypoints stop"), (True, "through_waypoints smooth")):
            a = clock()
            through_waypoints(wp, lim, smooth=smooth)
            plan_ns[key].append(clock() - a)
        t = traj.t_start + rng.uniform() * traj.duration
        state = traj.state_at(t)
        a = clock()
        retarget(t, *state, wp[:1], lim)
        plan_ns["retarget mid-motion"].append(clock() - a)
    return {"joints": n, "sample": percentiles_us(ns), "segments": len(traj.knots) - 1,
            "plans": plans, "planning": {k: percentiles_us(v) for k, v in plan_ns.items()}}


def format_table(result: dict) -> str:
    s = result["sample"]
    lines = [f"trajectory, {result['joints']} joints",
             f"sample() µs ({result['segments']} segments): p50 {s['p50_us']:.2f}  p99 {s['p99_us']:.2f}  "
             f"max {s['max_us']:.1f}",
             f"{'planning, ms (' + str(result['plans']) + ' plans)':<30}{'p50':>8}{'p99':>8}{'max':>8}"]
    for label, p in result["planning"].items():
        lines.append(f"{label:<30}{p['p50_us'] / 1e3:>8.2f}{p['p99_us'] / 1e3:>8.2f}{p['max_us'] / 1e3:>8.2f}")
    return "\n".join(lines)
