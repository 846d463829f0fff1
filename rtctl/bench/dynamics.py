"""``rtctl bench dynamics``: µs per call of the dynamics algorithms, with Pinocchio beside them.

For each algorithm, three forms of ours and Pinocchio's Python binding, on the same states:

* ``api``      — the convenience function (packs the model, allocates a workspace and the result);
* ``into``     — the hot-path form ``*_into(arrays, data, …)`` from Python (numba dispatch included);
* ``compiled`` — the kernel called from compiled code (a numba loop), as a simulator substep
  loop or a compiled controller would: the cost of the arithmetic alone;
* ``pinocchio`` — ``pin.rnea``, ``pin.crba``, ``pin.computeCoriolisMatrix``, ``pin.aba``,
  ``pin.computeGeneralizedGravity`` called from Python (C++ plus boost.python dispatch).

Pinocchio has only the Christoffel C, so the C* row is timed against the same figure. Each
figure is the median over batches of calls after a warm-up; the machine's other load shows in
the spread, so compare ratios taken in one run.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from numba import njit

from rtctl.bench import median_us
from rtctl.model import dynamics as dyn
from rtctl.model import load_robot
from rtctl.model.coriolis import coriolis_kernel
from rtctl.model.crba import crba_kernel
from rtctl.model.forward_dynamics import forward_dynamics_kernel
from rtctl.model.rnea import rnea_kernel

DEFAULT_ROBOT = Path(__file__).resolve().parents[2] / "configs" / "robots" / "puma560.toml"
BATCH = 25


def _median_us(fn, repeats: int) -> float:
    return median_us(fn, repeats, BATCH)


# Compiled callers: `count` kernel calls inside numba, the per-call cost without dispatch.
@njit(cache=True)
def _rnea_loop(count, joint, geom, params, gravity, X, body, q, qd, qdd, tau):
    for _ in range(count):
        rnea_kernel(joint, geom, params, gravity, X, body, q, qd, qdd, tau)


@njit(cache=True)
def _gravity_loop(count, joint, geom, params, gravity, X, body, q, zero, g):
    for _ in range(count):
        rnea_kernel(joint, geom, params, gravity, X, body, q, zero, zero, g)


@njit(cache=True)
def _crba_loop(count, joint, geom, params, X, body, Ic, q, H):
    for _ in range(count):
        crba_kernel(joint, geom, params, X, body, Ic, q, H)


@njit(cache=True)
def _coriolis_loop(count, joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, kind, C):
    for _ in range(count):
        coriolis_kernel(joint, geom, params, gravity, X, body, Ic, I6, B6, W, q, qd, zero, kind, C)


@njit(cache=True)
def _fd_loop(count, joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, armature, qdd):
    for _ in range(count):
        forward_dynamics_kernel(joint, geom, params, gravity, X, body, Ic, H, q, qd, tau, armature, qdd)


def _compiled_us(loop, args, repeats: int) -> float:
    loop(1, *args)  # compile or load from cache
    count = max(repeats // 5, 200)
    samples = []
    for _ in range(15):
        t0 = time.perf_counter_ns()
        loop(count, *args)
        samples.append((time.perf_counter_ns() - t0) / count / 1e3)
    return float(np.median(samples))


def bench_dynamics(robot_path=DEFAULT_ROBOT, repeats: int = 5000) -> dict:
    """Measure the table (see module docstring); returns a JSON-able dict with ``rows``."""
    model = load_robot(robot_path or DEFAULT_ROBOT)
    n = model.nq
    rng = np.random.default_rng(0)
    q, qd, qdd, tau = (rng.uniform(-1, 1, n) for _ in range(4))
    arrays, data = dyn.model_arrays(model), dyn.Data(model)
    a, d = arrays, data
    out, M = np.zeros(n), np.zeros((n, n))
    armature = np.zeros(n)
    ours = {
        "rnea": (lambda: dyn.rnea(model, q, qd, qdd),
                 lambda: dyn.rnea_into(a, d, q, qd, qdd, out),
                 (_rnea_loop, (*a, d.X, d.body, q, qd, qdd, out))),
        "gravity": (lambda: dyn.gravity(model, q),
                    lambda: dyn.gravity_into(a, d, q, out),
                    (_gravity_loop, (*a, d.X, d.body, q, d.zero, out))),
        "mass_matrix": (lambda: dyn.mass_matrix(model, q),
                        lambda: dyn.mass_matrix_into(a, d, q, M),
                        (_crba_loop, (a.joint, a.geom, a.params, d.X, d.body, d.Ic, q, M))),
        "coriolis_matrix christoffel": (
            lambda: dyn.coriolis_matrix(model, q, qd, "christoffel"),
            lambda: dyn.coriolis_matrix_into(a, d, q, qd, dyn.CHRISTOFFEL, M),
            (_coriolis_loop, (*a, d.X, d.body, d.Ic, d.I6, d.B6, d.M6, q, qd, d.zero, dyn.CHRISTOFFEL, M))),
        "coriolis_matrix cstar": (
            lambda: dyn.coriolis_matrix(model, q, qd, "cstar"),
            lambda: dyn.coriolis_matrix_into(a, d, q, qd, dyn.CSTAR, M),
            (_coriolis_loop, (*a, d.X, d.body, d.Ic, d.I6, d.B6, d.M6, q, qd, d.zero, dyn.CSTAR, M))),
        "forward_dynamics": (
            lambda: dyn.forward_dynamics(model, q, qd, tau),
            lambda: dyn.forward_dynamics_into(a, d, q, qd, tau, armature, out),
            (_fd_loop, (*a, d.X, d.body, d.Ic, d.H, q, qd, tau, armature, out))),
    }
    theirs, pin_version = _pinocchio_calls(model, q, qd, qdd, tau)
    rows = []
    for name, (api, into, (loop, args)) in ours.items():
        row = {"op": name, "api_us": _median_us(api, repeats // 5), "into_us": _median_us(into, repeats),
               "compiled_us": _compiled_us(loop, args, repeats)}
        if theirs:
            row["pinocchio_us"] = _median_us(theirs[name], repeats)
            row["into_over_pinocchio"] = row["into_us"] / row["pinocchio_us"]
            row["compiled_over_pinocchio"] = row["compiled_us"] / row["pinocchio_us"]
        rows.append(row)
    return {"bench": "dynamics", "robot": model.name, "n": n, "repeats": repeats,
            "pinocchio": pin_version, "rows": rows}


def _pinocchio_calls(model, q, qd, qdd, tau):
    """Pinocchio's counterparts on the same robot (through to_urdf), or ({}, None)."""
    try:
        import pinocchio as pin
    except ImportError:
        return {}, None
    pm = pin.buildModelFromXML(model.to_urdf())
    pd = pm.createData()
    pq = np.zeros(pm.nq)
    for joint, value in zip(list(pm.joints)[1:], q):  # continuous joints are (cos, sin) there
        pq[joint.idx_q:joint.idx_q + joint.nq] = (np.cos(value), np.sin(value)) if joint.nq == 2 else value
    coriolis = lambda: pin.computeCoriolisMatrix(pm, pd, pq, qd)  # noqa: E731
    return {
        "rnea": lambda: pin.rnea(pm, pd, pq, qd, qdd),
        "gravity": lambda: pin.computeGeneralizedGravity(pm, pd, pq),
        "mass_matrix": lambda: pin.crba(pm, pd, pq),
        "coriolis_matrix christoffel": coriolis,
        "coriolis_matrix cstar": coriolis,
        "forward_dynamics": lambda: pin.aba(pm, pd, pq, qd, tau),
    }, pin.__version__


def format_table(result: dict) -> str:
    """The result as a fixed-width table (µs per call; ratios ours / Pinocchio)."""
    has_pin = result["pinocchio"] is not None
    head = f"{'algorithm':<28}{'api':>9}{'into':>9}{'compiled':>10}"
    if has_pin:
        head += f"{'pinocchio':>11}{'into/pin':>10}{'comp/pin':>10}"
    lines = [f"dynamics on {result['robot']} (n = {result['n']}), µs per call, median"
             + (f"; Pinocchio {result['pinocchio']} from Python" if has_pin else "; Pinocchio not installed"),
             head, "-" * len(head)]
    for r in result["rows"]:
        line = f"{r['op']:<28}{r['api_us']:>9.2f}{r['into_us']:>9.2f}{r['compiled_us']:>10.2f}"
        if has_pin:
            line += (f"{r['pinocchio_us']:>11.2f}{r['into_over_pinocchio']:>10.2f}"
                     f"{r['compiled_over_pinocchio']:>10.2f}")
        lines.append(line)
    lines.append("api: convenience function; into: *_into from Python; compiled: kernel called from numba code")
    return "\n".join(lines)
