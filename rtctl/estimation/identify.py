"""Offline identification: the Sage–Husa filter run over recorded inputs and outputs.

:func:`identify` fits the ARX model of :mod:`rtctl.estimation.arx` to arrays; :func:`identify_run`
to a telemetry file (y = the measured position ``q``, u = the commanded torque ``tau``, resampled
every ``period`` seconds — the controller's sample time); ``rtctl identify`` prints the result.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.errors import ConfigError, RtctlError
from rtctl.estimation.arx import MAX_ORDER, ArxOrder, push_history, regressor_into
from rtctl.estimation.sage_husa import EPS, PRED_ERR, SageHusa, sage_husa_step
from rtctl.jsonout import dumps


def identify(y, u, order: ArxOrder = ArxOrder(), **filter_options) -> dict:
    """Run the filter over ``y`` and ``u`` ((N,) or (N, m): one column per channel). Histories
    start from y(0) and u = 0; the first sample only fills them. ``filter_options`` go to
    :class:`~rtctl.estimation.sage_husa.SageHusa` (default θ̂(0) = 0 with P(0) = 10³·I, the usual
    start of a least-squares fit). Returns θ̂, r̂, R̂ at the end, ε and y − hᵀθ̂(k|k−1) per sample
    (N − 1, m), and the RMS of the one-step prediction error ε."""
    y, u = np.asarray(y, dtype=float), np.asarray(u, dtype=float)
    if y.ndim == 1:
        y, u = y[:, None], u[:, None] if u.ndim == 1 else u
    if y.ndim != 2 or u.shape != y.shape or len(y) < 2:
        raise ValueError(f"y and u must have the same shape (N,) or (N, m) with N ≥ 2, got {y.shape}, {u.shape}")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(u))):
        raise ValueError("y and u must be finite")
    N, m = y.shape
    options = {"theta0": 0.0, "P0": 1e3, **filter_options}
    f = SageHusa(m, order.p, **options)
    y_hist = np.repeat(y[:1], order.na, axis=0)
    u_hist = np.zeros((order.memory, m))
    h, eps, pred = np.zeros(order.p), np.zeros((N - 1, m)), np.zeros((N - 1, m))
    for i in range(m):
        push_history(i, y_hist, u_hist, y[0, i], u[0, i])
    for k in range(1, N):
        for i in range(m):
            regressor_into(i, y_hist, u_hist, order.d, h)
            sage_husa_step(i, f.theta, f.P, f.q_hat, f.Q_hat, f.signals, f.fade, h, y[k, i], f.lam, f.switches,
                           f.R_min, f.Q_min, f._Ph, f._old)
            push_history(i, y_hist, u_hist, y[k, i], u[k, i])
        eps[k - 1], pred[k - 1] = f.signals[EPS], f.signals[PRED_ERR]
    return {"order": order, "theta": f.theta.T.copy(), "r_hat": f.r_hat.copy(), "R_hat": f.R_hat.copy(),
            "eps": eps, "prediction_error": pred, "eps_rms": np.sqrt(np.mean(eps ** 2, axis=0))}


def identify_run(path, joints=None, period: float | None = None, order: ArxOrder = ArxOrder(),
                 **filter_options) -> dict:
    """:func:`identify` on a telemetry file; ``joints``: names (default all), ``period``: the
    sample time in seconds (default: every recorded tick)."""
    from rtctl.telemetry import read

    tel = read(path)
    tel.require_rows("identify", 2)
    for col in ("q", "tau"):
        if col not in tel:
            raise RtctlError(f"{path}: no column {col!r} to identify from (columns: {', '.join(tel.columns)})")
    names = list(tel.meta.get("joints") or [f"j{k + 1}" for k in range(tel["q"].reshape(tel.rows, -1).shape[1])])
    idx = list(range(len(names)))
    if joints:
        unknown = [j for j in joints if j not in names]
        if unknown:
            raise RtctlError(f"unknown joint {unknown[0]!r}; the run has {', '.join(names)}")
        idx = [names.index(j) for j in joints]
    rate = float(tel.meta.get("rate_hz", 0.0)) or None
    every = 1
    if period is not None:
        if rate is None:
            raise RtctlError(f"{path}: the recording does not say its rate; cannot resample at {period} s")
        every = max(1, round(period * rate))
    q, tau = tel["q"].reshape(tel.rows, -1)[::every, idx], tel["tau"].reshape(tel.rows, -1)[::every, idx]
    if len(q) < 2:
        raise RtctlError(f"{path}: {tel.rows} rows give {len(q)} sample(s) every {period} s: at least 2 needed")
    result = identify(q, tau, order, **filter_options)
    result["joints"] = [names[i] for i in idx]
    result["period"] = every / rate if rate else None
    result["rows"], result["samples"], result["incomplete"] = tel.rows, len(q), tel.incomplete
    return result


def format_result(result: dict) -> str:
    order = result["order"]
    head = (f"ARX(na={order.na}, nb={order.nb}, d={order.d}), sample time "
            + (f"{result['period']:g} s" if result.get("period") else "one recorded tick"))
    cols = order.names()
    head += f"; {result['samples']} samples of {result['rows']} recorded rows" if "rows" in result else ""
    lines = [head] + ([f"note: {result['incomplete']}"] if result.get("incomplete") else []) + [f"{'joint':<12}" + "".join(f"{c:>13}" for c in cols) + f"{'r̂':>13}{'R̂':>12}{'rms ε':>12}"]
    for j, name in enumerate(result["joints"]):
        lines.append(f"{name:<12}" + "".join(f"{x:>13.6g}" for x in result["theta"][j])
                     + f"{result['r_hat'][j]:>13.4g}{result['R_hat'][j]:>12.3g}{result['eps_rms'][j]:>12.3g}")
    return "\n".join(lines)


def _check_arguments(args) -> None:
    """Exit 2 naming the option, before anything is read or allocated."""
    def bad(option, expected):
        return ConfigError("<command line>", option, expected)

    for option, high in MAX_ORDER.items():
        value = getattr(args, option)
        if not 1 <= value <= high:
            raise bad(f"--{option}", f"an integer from 1 to {high}, got {value}")
    if args.period is not None and not (math.isfinite(args.period) and args.period > 0):
        raise bad("--period", f"seconds > 0, got {args.period}")
    if not 0.0 < args.lam < 1.0:
        raise bad("--lam", f"a number in (0, 1), got {args.lam}")
    if not (math.isfinite(args.p0) and args.p0 > 0):
        raise bad("--p0", f"a number > 0, got {args.p0}")
    if not (math.isfinite(args.r0) and args.r0 >= 0):
        raise bad("--r0", f"a number ≥ 0, got {args.r0}")


def main(args) -> int:
    """``rtctl identify``: print θ̂, r̂, R̂ and the RMS one-step prediction error per joint."""
    joints = [j for part in (args.joints or []) for j in part.split(",") if j]
    _check_arguments(args)
    if args.json:
        from rtctl.outputs import output_path

        args.json = output_path(args.json, "--json")
    try:
        order = ArxOrder(args.na, args.nb, args.d)
        result = identify_run(args.path, joints, args.period, order, lam=args.lam, adapt=tuple(args.adapt),
                              P0=args.p0, R0=args.r0)
    except ValueError as e:
        raise RtctlError(str(e)) from None
    print(format_result(result))
    if args.json:
        out = {k: v for k, v in result.items() if k not in ("eps", "prediction_error")}
        out["order"] = {"na": order.na, "nb": order.nb, "d": order.d}
        with open(args.json, "w") as f:
            f.write(dumps(out, indent=2))  # strict: a diverged estimate is null, not NaN
    return 0
