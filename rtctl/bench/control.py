"""``rtctl bench control``: the cost of one Slotine–Li tick (τ + adaptation), both laws, and one
``arma_gmv`` update (:mod:`rtctl.bench.arma_gmv`).

For random all-revolute chains of n = 2, 6, 12, 24 joints and the PUMA 560 (or ``--robot``):

* ``tick``      — ``SlotineLi.update()`` called from Python once per tick, as the loop calls it:
                  one compiled kernel (Euler step of π̂, both recursions) plus the method call and
                  numba's dispatch (~1–2 µs of it is not arithmetic);
* ``compiled``  — the same kernel called from a numba loop: the arithmetic alone;
* ``pinocchio`` — the same τ (no adaptation) assembled from Pinocchio in this process:
                  ``crba`` + ``computeCoriolisMatrix`` + ``computeGeneralizedGravity`` and
                  τ = H q̈_r + C q̇_r + G − K_D s with numpy (q̇_r, q̈_r, s included);
* operation counts (multiplications / additions per tick, :mod:`rtctl.control.opcount`).

Goals reported against: C* tick ≤ 0.5 × Pinocchio's τ-only assembly; C*/classic ≤ 0.75;
linear in n (t₂₄ / t₆ ≤ 4.5). Medians over batches; compare ratios taken in one run.
"""
from __future__ import annotations

import time

import numpy as np
from numba import njit

from rtctl.bench import compiled_us, median_us
from rtctl.control.base import Reference
from rtctl.control.computed_torque import ComputedTorque, computed_torque_kernel
from rtctl.control.pd_gravity import PDGravity, pd_gravity_kernel
from rtctl.control.opcount import count_slotine_li_tick
from rtctl.control.slotine_li import LAWS, SlotineLi
from rtctl.control.slotine_li_kernels import STEP, slotine_li_update_kernel
from rtctl.hal.joints import JointCommand, JointState
from rtctl.model import REVOLUTE, Model, load_robot
from rtctl.model.dh import inertial_params
from rtctl.model.rotations import rot_axis

SIZES = (2, 6, 12, 24)
BATCH = 50


def random_chain(n: int, seed: int = 0) -> Model:
    """A generic serial chain of revolute joints: random axes, placements, consistent inertias."""
    rng = np.random.default_rng(seed)

    def rotation():
        axis = rng.normal(size=3)
        return rot_axis(axis / np.linalg.norm(axis), rng.uniform(-np.pi, np.pi))

    params = []
    for _ in range(n):
        m = rng.uniform(0.5, 5.0)
        second = rng.uniform(0.002, 0.05, 3) * m
        R = rotation()
        principal = np.diag([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
        params.append(inertial_params(m, rng.uniform(-0.3, 0.3, 3), R @ principal @ R.T))
    axes = rng.normal(size=(n, 3))
    return Model(name=f"chain{n}", joint_names=tuple(f"j{i + 1}" for i in range(n)),
                 joint_types=np.full(n, REVOLUTE, dtype=np.int64), parent=np.arange(n, dtype=np.int64) - 1,
                 axis=axes / np.linalg.norm(axes, axis=1, keepdims=True),
                 R_tree=np.array([rotation() for _ in range(n)]), p_tree=rng.uniform(-0.5, 0.5, (n, 3)),
                 params=np.array(params), q_min=np.full(n, -3.0), q_max=np.full(n, 3.0))


def _median_us(fn, repeats: int) -> float:
    return median_us(fn, repeats, BATCH)


@njit(cache=True)
def _update_loop(count, settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, fresh, ref,
                 signals, params_dot, mask, tau_out):
    for _ in range(count):
        slotine_li_update_kernel(settings, joint, geom, params, gravity, gains, gamma, X, body, work, q, qd, fresh,
                                 ref, signals, params_dot, mask, tau_out)


@njit(cache=True)
def _ct_loop(count, joint, geom, params, gravity, X, body, q, qd, ref, gains, coulomb_velocity, signals, mask, tau):
    for _ in range(count):
        computed_torque_kernel(joint, geom, params, gravity, X, body, q, qd, ref, gains, coulomb_velocity, signals,
                               mask, tau)


@njit(cache=True)
def _pd_loop(count, joint, geom, params, gravity, X, body, zero, q, qd, ref, kp, kd, g, tau, mask, tau_out):
    for _ in range(count):
        pd_gravity_kernel(joint, geom, params, gravity, X, body, zero, q, qd, ref, kp, kd, g, tau, mask, tau_out)


def _time_model_based(model, state, repeats) -> dict:
    """Computed torque and PD + gravity on ``model``: update() from Python against its kernel in
    a numba loop (the gap is what the call costs: the goal is ≤ 1.5 µs)."""
    n = model.nq
    js, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    js.position[:], js.velocity[:], ref.q[:], ref.qd[:], ref.qdd[:] = state
    ct, pd = ComputedTorque("ct", model, kp=100.0, kd=20.0), PDGravity("pd", model, kp=100.0, kd=20.0)
    rows = {}
    for name, c, loop, args in (
            ("computed_torque", ct, _ct_loop, (ct.arrays.joint, ct.arrays.geom, ct.arrays.params, ct.arrays.gravity,
                                               ct.data.X, ct.data.body, js.position, js.velocity, ref.packed,
                                               ct.gains, ct.coulomb_velocity, ct.signals, ct.mask, cmd.tau_ff)),
            ("pd_gravity", pd, _pd_loop, (pd.arrays.joint, pd.arrays.geom, pd.arrays.params, pd.arrays.gravity,
                                          pd.data.X, pd.data.body, pd.data.zero, js.position, js.velocity,
                                          ref.packed, pd.kp, pd.kd, pd.g, pd.tau, pd.mask, cmd.tau_ff))):
        tick = _median_us(lambda c=c: c.update(0.0, js, ref, cmd), repeats)
        compiled = compiled_us(loop, args)
        rows[name] = {"tick_us": tick, "compiled_us": compiled, "call_us": tick - compiled}
    return rows


def _state(model, rng):
    n = model.nq
    return [rng.uniform(-1, 1, n) for _ in range(5)]


def _time_law(model, law, state, repeats):
    n = model.nq
    c = SlotineLi(model, law=law, lam=5.0, kd=10.0, gamma=0.01)
    js, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    js.position[:], js.velocity[:], ref.q[:], ref.qd[:], ref.qdd[:] = state
    clock = [0.0]

    def tick():
        clock[0] += 1e-9  # a tiny Euler step each tick, so the estimates stay put
        c.update(clock[0], js, ref, cmd)

    tick_us = _median_us(tick, repeats)
    m = c.arrays
    settings = c.settings.copy()
    settings[STEP] = 1e-9
    args = (settings, m.joint, m.geom, c.params_hat, m.gravity, c.gains, c.gamma, *c._work, js.position, js.velocity,
            js.fresh, ref.packed, c.signals, c.params_dot, c.mask, cmd.tau_ff)
    _update_loop(1, *args)
    count = 2000
    samples = []
    for _ in range(7):
        t0 = time.perf_counter_ns()
        _update_loop(count, *args)
        samples.append((time.perf_counter_ns() - t0) / count / 1e3)
    tally, _, _ = count_slotine_li_tick(model, law, state, model.params, c.gamma, c.lam, c.kd)
    return {"tick_us": tick_us, "compiled_us": float(np.median(samples)), "mul": tally.mul, "add": tally.add}


def _time_pinocchio(model, state, repeats):
    try:
        import pinocchio as pin
    except ImportError:
        return None
    pm = pin.buildModelFromXML(model.to_urdf())
    if pm.nq != model.nq:
        return None
    pd = pm.createData()
    q, qd, q_d, qd_d, qdd_d = state
    lam, kd = np.full(model.nq, 5.0), np.full(model.nq, 10.0)

    def tick():
        qdr = qd_d - lam * (q - q_d)
        qddr = qdd_d - lam * (qd - qd_d)
        s = qd - qdr
        H = pin.crba(pm, pd, q)
        C = pin.computeCoriolisMatrix(pm, pd, q, qd)
        G = pin.computeGeneralizedGravity(pm, pd, q)
        return H @ qddr + C @ qdr + G - kd * s

    return _median_us(tick, repeats)


def bench_control(robot_path, repeats: int = 4000) -> dict:
    from rtctl.bench.arma_gmv import bench_arma_gmv

    arma = bench_arma_gmv(repeats)
    rng = np.random.default_rng(0)
    models = [random_chain(n, seed=n) for n in SIZES] + [load_robot(robot_path)]
    rows = []
    for model in models:
        state = _state(model, rng)
        row = {"robot": model.name, "n": model.nq}
        for law in LAWS:
            row[law] = _time_law(model, law, state, repeats)
        row["pinocchio_tau_us"] = _time_pinocchio(model, state, repeats)
        row["model_based"] = _time_model_based(model, state, repeats)
        row["cstar_over_classic"] = row["cstar"]["tick_us"] / row["classic"]["tick_us"]
        row["cstar_over_classic_compiled"] = row["cstar"]["compiled_us"] / row["classic"]["compiled_us"]
        pin_us = row["pinocchio_tau_us"]
        row["cstar_over_pinocchio"] = None if pin_us is None else row["cstar"]["tick_us"] / pin_us
        rows.append(row)
    by_n = {r["n"]: r for r in rows[:len(SIZES)]}
    growth = {law: by_n[24][law]["tick_us"] / by_n[6][law]["tick_us"] for law in LAWS}
    growth_compiled = {law: by_n[24][law]["compiled_us"] / by_n[6][law]["compiled_us"] for law in LAWS}
    puma = rows[-1]
    goals = {
        "cstar_tick_le_half_pinocchio": None if puma["cstar_over_pinocchio"] is None else puma["cstar_over_pinocchio"] <= 0.5,
        "cstar_over_classic_le_0.75": puma["cstar_over_classic"] <= 0.75,
        "t24_over_t6_le_4.5": growth["cstar"] <= 4.5,
        "every_update_within_1.5us_of_its_kernel": all(
            r[law]["tick_us"] - r[law]["compiled_us"] <= 1.5 for r in rows for law in LAWS)
        and all(m["call_us"] <= 1.5 for r in rows for m in r["model_based"].values()),
    }
    return {"rows": rows, "t24_over_t6": growth, "t24_over_t6_compiled": growth_compiled, "goals": goals,
            "arma_gmv": arma,
            "note": "tick = SlotineLi.update() from Python once per tick (what the loop does); compiled = the "
                    "kernel in a numba loop; pinocchio = tau only (no adaptation), from Python"}


def format_table(result: dict) -> str:
    head = (f"{'robot':<10}{'n':>3} | {'C* tick':>8}{'classic':>8}{'ratio':>7} | {'C* comp':>8}{'classic':>8}"
            f"{'ratio':>7} | {'pin τ':>7}{'C*/pin':>7} | {'C* mul/add':>12}{'classic mul/add':>16}")
    lines = ["Slotine–Li tick (τ + adaptation), µs; tick = update() from Python, comp = kernel in a numba loop",
             head, "-" * len(head)]
    for r in result["rows"]:
        c, k = r["cstar"], r["classic"]
        pin_us = r["pinocchio_tau_us"]
        pin_txt = f"{pin_us:7.2f}{r['cstar_over_pinocchio']:7.2f}" if pin_us is not None else f"{'—':>7}{'—':>7}"
        lines.append(f"{r['robot']:<10}{r['n']:>3} | {c['tick_us']:8.2f}{k['tick_us']:8.2f}{r['cstar_over_classic']:7.2f}"
                     f" | {c['compiled_us']:8.2f}{k['compiled_us']:8.2f}{r['cstar_over_classic_compiled']:7.2f}"
                     f" | {pin_txt} | {c['mul']:>6}/{c['add']:<5}{k['mul']:>9}/{k['add']:<6}")
    g, gc = result["t24_over_t6"], result["t24_over_t6_compiled"]
    lines.append(f"t24/t6: C* {g['cstar']:.2f} (compiled {gc['cstar']:.2f}), classic {g['classic']:.2f} "
                 f"(compiled {gc['classic']:.2f})")
    lines.append("update() from Python − its kernel in a numba loop (µs; goal ≤ 1.5): "
                 + ", ".join(f"{r['robot']} C* {r['cstar']['tick_us'] - r['cstar']['compiled_us']:.2f} "
                             f"classic {r['classic']['tick_us'] - r['classic']['compiled_us']:.2f} "
                             f"CT {r['model_based']['computed_torque']['call_us']:.2f} "
                             f"PD {r['model_based']['pd_gravity']['call_us']:.2f}" for r in result["rows"]))
    lines.append("goals (PUMA row, C* tick): " + ", ".join(f"{k}: {'yes' if v else ('n/a' if v is None else 'NO')}"
                                                            for k, v in result["goals"].items()))
    if "arma_gmv" in result:
        from rtctl.bench.arma_gmv import format_rows

        lines += [""] + format_rows(result["arma_gmv"])
    return "\n".join(lines)
