"""The ``arma_gmv`` row of ``rtctl bench control``: one controller update (Sage–Husa step + GMV
per joint) for 3 and 6 joints — ``ArmaGmv.update()`` from Python as the loop calls it, and the
kernel from a numba loop — next to filterpy's KalmanFilter predict + update for one joint (the
same filter with its adaptations off, in numpy). Goals: ≤ 4 µs per 6-joint update from Python,
and per joint ≥ 20× faster than filterpy."""
from __future__ import annotations


import numpy as np

from rtctl.bench import compiled_us, median_us
from rtctl.compiled import kernel
from rtctl.control.arma_gmv import ArmaGmv, arma_gmv_kernel
from rtctl.control.base import Reference
from rtctl.hal.joints import JointCommand, JointState
from rtctl.model import REVOLUTE, Model

BATCH = 50


def _chain(n: int) -> Model:
    return Model(name=f"chain{n}", joint_names=tuple(f"j{i + 1}" for i in range(n)),
                 joint_types=np.full(n, REVOLUTE, dtype=np.int64), parent=np.arange(n, dtype=np.int64) - 1,
                 axis=np.tile([0.0, 0.0, 1.0], (n, 1)), R_tree=np.tile(np.eye(3), (n, 1, 1)),
                 p_tree=np.zeros((n, 3)), params=np.tile([1.0] + [0.0] * 3 + [0.1] * 3 + [0.0] * 3, (n, 1)),
                 q_min=np.full(n, -3.0), q_max=np.full(n, 3.0))


@kernel
def _kernel_loop(count, iset, position, ref, filter_state, work, tau):
    for _ in range(count):
        arma_gmv_kernel(iset, position, ref, filter_state, work, tau)


def _controller(n: int):
    c = ArmaGmv(_chain(n), theta0=[2.0, -1.0, 1e-4, 1e-4, 0.0], P0=[1e-6, 1e-6, 1e-12, 1e-12, 1e-12], rho=1e-9,
                Q0=1e-14, adapt=("r", "R"))
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    rng = np.random.default_rng(n)
    state.position[:] = rng.uniform(-1, 1, n)
    ref.q[:] = state.position + 0.01
    c.reset(state)
    return c, state, ref, cmd


def _time_update(n: int, repeats: int) -> dict:
    c, state, ref, cmd = _controller(n)
    clock = [0.0]

    def tick():
        clock[0] += 0.02
        c.update(clock[0], state, ref, cmd)

    tick_us = median_us(tick, repeats, BATCH)
    args = (c.iset, state.position, ref.packed, c.filter.state, c.work, cmd.tau_ff)
    return {"n": n, "tick_us": tick_us, "compiled_us": compiled_us(_kernel_loop, args)}


def _time_filterpy(repeats: int) -> float | None:
    try:
        from filterpy.kalman import KalmanFilter
    except ImportError:
        return None
    kf = KalmanFilter(dim_x=5, dim_z=1)
    kf.x, kf.P, kf.Q, kf.R = np.zeros((5, 1)), np.eye(5), np.eye(5) * 1e-9, np.array([[1e-8]])
    H = np.array([[0.5, 0.5, 1.0, 1.0, 1.0]])

    def step():
        kf.predict()
        kf.update(0.1, H=H)

    return median_us(step, max(repeats // 10, 50), 10)


def bench_arma_gmv(repeats: int = 4000) -> dict:
    rows = [_time_update(n, repeats) for n in (3, 6)]
    fp = _time_filterpy(repeats)
    six = rows[1]
    per_joint = six["tick_us"] / 6
    goals = {"six_joint_update_le_4us": six["tick_us"] <= 4.0,
             "per_joint_ge_20x_filterpy": None if fp is None else fp / per_joint >= 20.0}
    return {"rows": rows, "filterpy_predict_update_us": fp, "per_joint_us": per_joint,
            "speedup_vs_filterpy": None if fp is None else fp / per_joint, "goals": goals}


def format_rows(result: dict) -> list[str]:
    lines = ["arma_gmv update (Sage–Husa step + GMV per joint, ARX(2, 2, 1)), µs; tick = update() from Python",
             f"{'joints':>7} | {'tick':>7} | {'compiled':>9}"]
    for r in result["rows"]:
        lines.append(f"{r['n']:>7} | {r['tick_us']:7.2f} | {r['compiled_us']:9.2f}")
    fp = result["filterpy_predict_update_us"]
    lines.append("filterpy KalmanFilter predict+update, one joint: "
                 + (f"{fp:.1f} µs; per joint ours {result['per_joint_us']:.2f} µs: {result['speedup_vs_filterpy']:.0f}×"
                    if fp is not None else "not installed"))
    lines.append("goals: " + ", ".join(f"{k}: {'yes' if v else ('n/a' if v is None else 'NO')}"
                                       for k, v in result["goals"].items()))
    return lines
