"""``rtctl bench safety``: what the safety stage costs the tick, per ``check()`` call, at n joints.

Cases: torque mode with the controllers in charge (state checks + command bounds), the same
with some joints in the soft-limit band, impedance mode, with a pass-through guard hook, and
in the fallback (hold) after a fault. Each call is timed alone with ``perf_counter_ns``
(its own ~0.1 µs included).
"""
from __future__ import annotations

import time

import numpy as np

from rtctl.bench import percentiles_us
from rtctl.hal.joints import CommandMode, JointCommand, JointState
from rtctl.safety import GuardVerdict, SafetyStage


class _PassGuard:
    reason = ""

    def check(self, t, state, command):
        return GuardVerdict.PASS


def _time_checks(stage, state, command, statuses, ticks, controller_ok=True) -> dict:
    ns = np.zeros(ticks, np.int64)
    clock = time.perf_counter_ns
    check = stage.check
    check(0.0, 0, state, statuses, command, controller_ok)  # loads the compiled kernels
    for k in range(ticks):
        command.tau_ff[0] = 1.0  # what a controller would write
        a = clock()
        check(k * 1e-3, k, state, statuses, command, controller_ok)
        ns[k] = clock() - a
    return percentiles_us(ns)


def bench_safety(n: int = 6, ticks: int = 20000) -> dict:
    def fresh(**options):
        stage = SafetyStage(np.full(n, -2.0), np.full(n, 2.0), np.full(n, 3.0), np.full(n, 10.0),
                            position_margin=0.1, **options)
        state, command = JointState(n), JointCommand(n)
        command.tau_ff[:] = np.linspace(-15.0, 15.0, n)
        return stage, state, command, np.zeros(1, np.int64)

    cases = {}
    stage, state, command, st = fresh()
    cases["torque"] = _time_checks(stage, state, command, st, ticks)
    state.position[: n // 2] = 1.95  # in the soft band
    cases["torque, soft band"] = _time_checks(stage, state, command, st, ticks)
    stage, state, command, st = fresh()
    command.mode = CommandMode.IMPEDANCE
    command.kp[:] = 50.0
    cases["impedance"] = _time_checks(stage, state, command, st, ticks)
    stage, state, command, st = fresh(guard=_PassGuard())
    cases["torque + guard hook"] = _time_checks(stage, state, command, st, ticks)
    stage, state, command, st = fresh()
    import structlog

    with structlog.testing.capture_logs():  # the one fault event, not on stdout
        stage.check(0.0, 0, state, st, command, False, "bench")
    cases["fallback (hold)"] = _time_checks(stage, state, command, st, ticks, controller_ok=True)
    return {"joints": n, "ticks": ticks, "cases": cases}


def format_table(result: dict) -> str:
    lines = [f"SafetyStage.check(), {result['joints']} joints, {result['ticks']} calls each",
             f"{'µs':<26}{'p50':>8}{'p99':>8}{'p99.9':>8}{'max':>9}"]
    for label, p in result["cases"].items():
        lines.append(f"{label:<26}{p['p50_us']:>8.2f}{p['p99_us']:>8.2f}{p['p99_9_us']:>8.2f}{p['max_us']:>9.1f}")
    return "\n".join(lines)
