"""``rtctl plot``: one PNG summarising a telemetry file.

Panels, each drawn only when its columns were recorded: joint tracking (``q`` against
``q_des``, one panel per joint), tracking errors ``q_des − q``, torques ``tau``, timing
histograms (every column named ``*_ns``: per-phase compute times, wake lateness), the
sliding variable ``s``, adaptive estimates (columns starting with ``params_hat`` or
``pi_hat``), and the tool marker seen by a camera (``marker_measured_px`` against
``marker_predicted_px``, and their difference ``marker_error_px``). The time axis is ``t``
when recorded, the tick index otherwise.

matplotlib is the optional extra ``plot``; it is imported here only, and drawn through its
object API with the Agg canvas (no pyplot state, no display needed).
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.errors import RtctlError
from rtctl.telemetry import read
from rtctl.timing import PHASES

ESTIMATE_PREFIXES = ("params_hat", "pi_hat")


def _figure_class():
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise RtctlError("plotting needs matplotlib, the optional extra `plot`: "
                         "pip install 'rtctl[plot]'") from None
    return Figure


def _per_joint(ax, t, values, title, ylabel):
    for j in range(values.shape[1]):
        ax.plot(t, values[:, j], lw=0.8, label=f"j{j + 1}")
    ax.set_title(title)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=6, ncol=3, loc="best")


def _columns(tel, name):
    return tel[name].reshape(tel.rows, -1)  # a scalar column (one joint) as a one-column matrix


def _tracking(t, tel, j):
    def draw(ax):
        if "q_des" in tel:
            ax.plot(t, _columns(tel, "q_des")[:, j], "--", lw=1.0, label="q_des")
        ax.plot(t, _columns(tel, "q")[:, j], lw=0.8, label="q")
        ax.set_title(f"joint {j + 1}")
        ax.set_ylabel("rad")
        ax.legend(fontsize=6, loc="best")
    return draw


def _timing(tel, names):
    def draw(ax):
        for name in names:
            values = _columns(tel, name) / 1e3
            labels = tel.meta.get(f"{name}_labels") or (PHASES if name == "phase_ns" and values.shape[1] == 5
                                                        else [f"{name}[{k}]" for k in range(values.shape[1])])
            for k in range(values.shape[1]):
                positive = values[:, k][values[:, k] > 0]
                if positive.size:
                    bins = np.geomspace(positive.min(), positive.max() * 1.0001, 60)
                    ax.hist(positive, bins=bins, histtype="step", label=labels[k] if values.shape[1] > 1 else name.removesuffix("_ns"))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title("timing per tick")
        ax.set_xlabel("µs")
        ax.legend(fontsize=6, loc="best")
    return draw


def _estimates(t, tel, names):
    def draw(ax):
        for name in names:
            ax.plot(t, _columns(tel, name), lw=0.6)
        ax.set_title("adaptive estimates: " + ", ".join(names))
    return draw


def _marker(t, tel):
    def draw(ax):
        measured, predicted = _columns(tel, "marker_measured_px"), _columns(tel, "marker_predicted_px")
        for k, axis in enumerate("uv"):
            ax.plot(t, predicted[:, k], "--", lw=1.0, label=f"{axis} predicted")
            ax.plot(t, measured[:, k], lw=0.8, label=f"{axis} measured")
        ax.set_title("tool marker in the image")
        ax.set_ylabel("px")
        ax.legend(fontsize=6, loc="best")
    return draw


def _marker_error(t, tel):
    def draw(ax):
        error = _columns(tel, "marker_error_px")
        for k, axis in enumerate("uv"):
            ax.plot(t, error[:, k], lw=0.8, label=axis)
        ax.set_title("marker measured − predicted")
        ax.set_ylabel("px")
        ax.legend(fontsize=6, loc="best")
    return draw


def _panels(tel):
    t = tel["t"] if "t" in tel else np.arange(tel.rows)
    panels = []
    if "q" in tel:
        panels += [_tracking(t, tel, j) for j in range(_columns(tel, "q").shape[1])]
    if "q" in tel and "q_des" in tel:
        error = _columns(tel, "q_des") - _columns(tel, "q")
        panels.append(lambda ax: _per_joint(ax, t, error, "tracking error q_des − q", "rad"))
    if "tau" in tel:
        panels.append(lambda ax: _per_joint(ax, t, _columns(tel, "tau"), "torque", "N·m"))
    timing = [name for name in tel.columns if name.endswith("_ns")]
    if timing:
        panels.append(_timing(tel, timing))
    if "s" in tel:
        panels.append(lambda ax: _per_joint(ax, t, _columns(tel, "s"), "sliding variable s", "rad/s"))
    if "marker_measured_px" in tel and "marker_predicted_px" in tel:
        panels += [_marker(t, tel), _marker_error(t, tel)]
    estimates = [name for name in tel.columns if name.startswith(ESTIMATE_PREFIXES)]
    if estimates:
        panels.append(_estimates(t, tel, estimates))
    return panels


def plot_run(path, out_png, columns: int = 3) -> None:
    """Draw the telemetry file ``path`` into the PNG ``out_png``."""
    Figure = _figure_class()
    tel = read(path)
    panels = _panels(tel)
    if not panels or tel.rows == 0:
        raise RtctlError(f"{path}: nothing to plot ({tel.rows} rows, columns: {', '.join(tel.columns)})")
    rows = math.ceil(len(panels) / columns)
    fig = Figure(figsize=(5 * columns, 3 * rows), layout="constrained")
    for k, draw in enumerate(panels):
        ax = fig.add_subplot(rows, columns, k + 1)
        ax.grid(True, lw=0.3)
        draw(ax)
        if not ax.get_xlabel():
            ax.set_xlabel("t (s)" if "t" in tel else "tick")
    meta = tel.meta
    fig.suptitle(f"{meta.get('config', path)} — {tel.rows} ticks"
                 + (f" at {meta['rate_hz']:g} Hz" if "rate_hz" in meta else "")
                 + (f", {tel.dropped_rows} rows dropped" if tel.dropped_rows else "")
                 + (" (file truncated)" if tel.truncated else ""))
    fig.savefig(out_png, dpi=90)
