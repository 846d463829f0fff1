"""``rtctl bench guard``: the run-time guard's cost per tick and the bypass planner's plan times.

* the per-tick check with 16 zones on 6 joints — :meth:`RuntimeGuard.check` called from
  Python (as the safety stage calls it) and the compiled :func:`guard_tick` alone (looped
  inside compiled code), in the common case (nothing ahead) and while clamping;
* the shipped scene (``configs/puma560_guard_sim.toml``): planning its route from the ready
  pose, the first time (the visibility graph among the zones' corners is built) and again
  (cached), and one bypass leg;
* for comparison, OMPL's RRT-Connect (the optional ``bench`` extra) on that leg in the
  shoulder–elbow plane, with the guard's depth test as its validity checker;
* the first compile of the guard's kernels (no numba cache), in a fresh process.
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit

from rtctl.guard import Box, Polygon, RuntimeGuard, Scene, Zone, plan_path, plan_route
from rtctl.guard import kernels as k
from rtctl.hal.joints import JointCommand, JointState

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "puma560_guard_sim.toml"
GOALS = {"tick_python_us": 5.0, "tick_compiled_us": 1.0, "plan_shipped_ms": 50.0}


def bench_scene(n: int = 6, zones: int = 16) -> Scene:
    """16 zones over 6 joints: hexagons in the planes of neighbouring joints and boxes over two
    or three joints, spread over the range so that a stopping path meets several of them."""
    rng = np.random.default_rng(7)
    out = []
    hexagon = np.stack([np.cos(np.arange(6) * np.pi / 3), np.sin(np.arange(6) * np.pi / 3)], axis=1)
    for z in range(zones):
        if z % 2 == 0:
            plane = (z % n, (z + 1) % n)
            out.append(Zone(f"hex{z}", [Polygon(plane, 0.3 * hexagon + rng.uniform(-1.5, 1.5, 2))]))
        else:
            joints = tuple(sorted(rng.choice(n, size=2 + z % 2, replace=False)))
            lo = rng.uniform(-1.5, 1.0, len(joints))
            out.append(Zone(f"box{z}", [Box(joints, lo, lo + 0.4)]))
    return Scene(out, [-3.0] * n, [3.0] * n, margin=0.05)


@njit(cache=True)
def _repeat(count, q, qd, mode, q_des, qd_des, tau, F, I):  # pragma: no cover
    v = 0
    for _ in range(count):
        v = k.guard_tick_packed(q, qd, mode, q_des, qd_des, tau, F, I)
    return v


def _tick_cases(scene: Scene) -> dict:
    n = scene.n
    out = {}
    for label, action, velocity in (("moving", "stop", 0.5), ("clamping", "clamp", None)):
        guard = RuntimeGuard(scene, 10.0, 1e-3, margin=0.02, action=action)
        state, command = JointState(n), JointCommand(n)
        state.position[:] = -2.6
        state.velocity[:] = velocity or 0.0
        if velocity is None:  # slowly up into the outer half of the guard margin under the first hexagon
            centre = scene.parts[0].vertices.mean(axis=0)
            i, j = scene.parts[0].joints
            state.position[[i, j]] = centre - [0.0, 0.3 * np.cos(np.pi / 6) + 0.018]
            state.velocity[[i, j]] = [0.0, 0.1]
        verdict = guard.check(0.0, state, command)
        args = (state.position, state.velocity, int(command.mode), command.q_des, command.qd_des, command.tau_ff,
                guard.F, guard.I)
        _repeat(1, *args)
        compiled, python = [], []
        check = guard.check
        for _ in range(31):  # interleaved batches: both see the same load
            t0 = time.perf_counter_ns()
            _repeat(5_000, *args)
            compiled.append((time.perf_counter_ns() - t0) / 5_000 / 1e3)
            t0 = time.perf_counter_ns()
            for _ in range(2_000):
                check(0.0, state, command)
            python.append((time.perf_counter_ns() - t0) / 2_000 / 1e3)
        out[label] = {"verdict": ("pass", "modified", "stop")[verdict],
                      "python_us": float(np.median(python)), "compiled_us": float(np.median(compiled)),
                      "python_min_us": float(min(python)), "compiled_min_us": float(min(compiled))}
    return out


def _ms(fn, repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        samples.append((time.perf_counter() - t0) * 1e3)
    return float(np.median(samples))


def _planning(repeats: int = 15) -> tuple[dict, dict]:
    from rtctl.config import load_config

    cfg = load_config(SHIPPED)
    scene, start = cfg.guard.scene, np.array(cfg.sim.data["initial_q"], float)
    waypoints = cfg.trajectory.waypoints

    def fresh():
        return Scene(scene.zones, scene.q_min, scene.q_max, scene.margin, scene.joint_names)

    plan_route(fresh(), start, waypoints)  # imports, kernels
    leg = plan_path(scene, waypoints[0], waypoints[1])
    rows = {
        "route, first plan (builds the graph)": _ms(lambda: plan_route(fresh(), start, waypoints), repeats),
        "route, again (graph cached)": _ms(lambda: plan_route(scene, start, waypoints), repeats),
        "one bypass leg, first plan": _ms(lambda: plan_path(fresh(), waypoints[0], waypoints[1]), repeats),
        "one bypass leg, again": _ms(lambda: plan_path(scene, waypoints[0], waypoints[1]), repeats),
    }
    route = plan_route(scene, start, waypoints)
    shipped = {"legs": len(route.legs), "bypassed": sum(p.crossing is not None for p in route.legs),
               "route_length_rad": route.length, "leg_length_rad": leg.length, "leg_points": len(leg.path),
               "leg_straight_rad": float(np.linalg.norm(waypoints[1] - waypoints[0]))}
    job = {"rows": scene.rows.tolist(), "cols": scene.cols.tolist(), "pieces": scene.pieces.tolist(),
           "template": waypoints[0].tolist(), "plane": [1, 2], "lo": scene.q_min[[1, 2]].tolist(),
           "hi": scene.q_max[[1, 2]].tolist(), "start": waypoints[0][[1, 2]].tolist(),
           "goal": waypoints[1][[1, 2]].tolist(), "margin": scene.margin,
           "resolution": 0.002, "timeout": 5.0, "runs": 20}
    # the 2-D leg alone (the other joints held) for the like-for-like comparison
    flat = waypoints[1].copy()
    flat[[0, 3, 4, 5]] = waypoints[0][[0, 3, 4, 5]]
    rows["the leg in its plane (visibility)"] = _ms(lambda: plan_path(scene, waypoints[0], flat), repeats)
    shipped["plane_leg_length_rad"] = plan_path(scene, waypoints[0], flat).length
    return rows, {"shipped": shipped, "ompl": _ompl(job)}


def _ompl(job) -> dict:
    if importlib.util.find_spec("ompl") is None:
        return {"available": False, "why": "OMPL is not installed: `.venv/bin/pip install -e '.[bench]'` adds it "
                                           "(its Python bindings; wheels for Linux x86-64)"}
    result = None
    try:
        result = subprocess.run([sys.executable, "-m", "rtctl.bench.guard_ompl"], input=json.dumps(job),
                                capture_output=True, text=True, timeout=300)
        runs = json.loads(result.stdout.splitlines()[0])["runs"]
    except (subprocess.SubprocessError, IndexError, ValueError, OSError) as e:
        why = result.stderr.strip().splitlines()[-1:] if result is not None else []
        return {"available": False, "why": f"OMPL is installed but did not run ({type(e).__name__}"
                                           + (f": {why[0]}" if why else "") + ")"}
    solved = [r for r in runs if r.get("length") is not None]
    if not solved:
        return {"available": True, "solved": 0, "runs": len(runs)}
    return {"available": True, "solved": len(solved), "runs": len(runs),
            "solve_ms": float(np.median([r["solve_ms"] for r in solved])),
            "with_simplify_ms": float(np.median([r["with_simplify_ms"] for r in solved])),
            "length_rad": float(np.median([r["length"] for r in solved])),
            "length_max_rad": float(max(r["length"] for r in solved))}


def _compile_s() -> float | None:
    code = ("import time; from rtctl.bench.guard import bench_scene; from rtctl.guard import RuntimeGuard; "
            "g = RuntimeGuard(bench_scene(), 10.0, 1e-3); t = time.perf_counter(); g.warm_up(); "
            "print(time.perf_counter() - t)")
    with tempfile.TemporaryDirectory() as cache:
        try:
            out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600,
                                 env={**os.environ, "NUMBA_CACHE_DIR": cache})
            return float(out.stdout.strip().splitlines()[-1])
        except (subprocess.SubprocessError, IndexError, ValueError):
            return None


def bench_guard() -> dict:
    scene = bench_scene()
    ticks = _tick_cases(scene)
    plans, extra = _planning()
    return {"zones": len(scene.zones), "joints": scene.n, "pieces": len(scene.pieces), "tick": ticks,
            "plan_ms": plans, **extra, "compile_s": _compile_s(), "load_average": os.getloadavg()[0],
            "cpus": os.cpu_count(),
            "goals": GOALS}


def format_table(r: dict) -> str:
    g = r["goals"]
    lines = [f"guard per tick: {r['zones']} zones on {r['joints']} joints ({r['pieces']} convex parts); median of 31 "
             "batches (fastest batch)",
             f"{'µs per check':<26}{'from Python':>18}{'compiled':>18}   goal ≤ {g['tick_python_us']:g} / ≤ {g['tick_compiled_us']:g}"]
    for label, c in r["tick"].items():
        lines.append(f"{label + ' (' + c['verdict'] + ')':<26}{c['python_us']:>9.2f} ({c['python_min_us']:.2f})"
                     f"{c['compiled_us']:>10.3f} ({c['compiled_min_us']:.3f})")
    s = r["shipped"]
    lines += ["", f"planning the shipped scene (configs/puma560_guard_sim.toml: {s['legs']} legs, {s['bypassed']} around "
                  f"the conveyor; route {s['route_length_rad']:.3f} rad)", f"{'ms (median)':<40}{'':>8}   goal ≤ {g['plan_shipped_ms']:g}"]
    for label, ms in r["plan_ms"].items():
        lines.append(f"{label:<40}{ms:>8.2f}")
    o = r["ompl"]
    lines.append("")
    if not o.get("available"):
        lines.append(f"OMPL RRT-Connect: {o.get('why', 'not available')}")
    elif not o.get("solved"):
        lines.append(f"OMPL RRT-Connect: no solution in {o['runs']} runs")
    else:
        lines.append(f"OMPL RRT-Connect, the same leg in the shoulder–elbow plane ({o['solved']}/{o['runs']} solved): "
                     f"solve {o['solve_ms']:.2f} ms, with simplification {o['with_simplify_ms']:.2f} ms; length "
                     f"{o['length_rad']:.3f} rad median, {o['length_max_rad']:.3f} max (visibility: "
                     f"{s['plane_leg_length_rad']:.3f} rad, the shortest)")
    if r.get("compile_s") is not None:
        lines.append(f"first compile of the guard kernels (no cache): {r['compile_s']:.1f} s")
    lines.append(f"load average {r['load_average']:.1f} on {r['cpus']} CPUs (others' work inflates the medians; "
                 "the fastest batch is the cost without interference)")
    return "\n".join(lines)
