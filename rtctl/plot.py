"""``rtctl plot``: one PNG summarising a telemetry file.

Panels, each drawn only when its columns were recorded: joint tracking (``q`` against
``q_des``, one panel per joint), tracking errors ``q_des − q``, torques ``tau``, timing
histograms (every column named ``*_ns``: per-phase compute times, wake lateness), the
sliding variable ``s``, adaptive estimates (columns starting with ``params_hat`` or
``pi_hat``), the leg automaton's gait phases (``leg_state`` with its gates, actions and
the foot loads), and the tool marker seen by a camera (``marker_measured_px`` against
``marker_predicted_px``, and their difference ``marker_error_px``). The time axis is ``t``
when recorded, the tick index otherwise.

matplotlib is the optional extra ``plot``; it is imported here only, and drawn through its
object API with the Agg canvas (no pyplot state, no display needed).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rtctl.errors import RtctlError
from rtctl.telemetry import read
from rtctl.timing import PHASES

ESTIMATE_PREFIXES = ("params_hat", "pi_hat")
# arma_gmv internals: column → (title, unit); a_hat / b_hat are (coefficients, joints) per row
ARMA_PANELS = {"r_hat": ("virtual-noise mean r̂", "rad"), "R_hat": ("virtual-noise variance R̂", "rad²"),
               "eps": ("innovation ε", "rad"), "u": ("GMV torque u", "N·m")}


def _figure_class():
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise RtctlError("plotting needs matplotlib, the optional extra `plot`: in the clone, "
                         ".venv/bin/pip install -e '.[plot]'") from None
    return Figure


def _joint_names(tel, count):
    names = tel.meta.get("joints") or []
    return list(names) if len(names) == count else [f"j{j + 1}" for j in range(count)]


def _per_joint(ax, t, values, title, ylabel, names):
    for j in range(values.shape[1]):
        ax.plot(t, values[:, j], lw=0.8, label=names[j])
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
        ax.set_title(f"joint {j + 1}: {_joint_names(tel, _columns(tel, 'q').shape[1])[j]}")
        ax.set_ylabel("rad")
        ax.legend(fontsize=6, loc="best")
    return draw


def _timing(tel, names):
    def draw(ax):
        for name in names:
            values = _columns(tel, name) / 1e3
            phases = tel.meta.get("phases") or PHASES  # (files before the "serve" phase name no phases)
            labels = tel.meta.get(f"{name}_labels") or (phases if name == "phase_ns" and values.shape[1] == len(phases)
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
        ax.set_ylabel("ticks")
        ax.legend(fontsize=6, loc="best")
    return draw


# the 10 inertial parameters of a link, in order: m, m·c (3), J (6) — one line style each
_PARAM_STYLES = (("-", "m (kg)", 1), ("--", "m·c (kg·m)", 3), (":", "J (kg·m²)", 6))


def _estimates(t, tel, names):
    """Each link's 10 parameters in the link's colour, the style telling mass, first moment and
    inertia apart; a column that is not 10 per joint gets one colour per column."""
    joints = tel.meta.get("joints") or []

    def draw(ax):
        from matplotlib.lines import Line2D

        handles = []
        for name in names:
            values = _columns(tel, name)
            per_link = len(joints) > 0 and values.shape[1] == 10 * len(joints)
            if not per_link:
                for k in range(values.shape[1]):
                    ax.plot(t, values[:, k], lw=0.6, label=f"{name}[{k}]" if values.shape[1] > 1 else name)
                continue
            for i, joint in enumerate(joints):
                colour = f"C{i % 10}"
                first = 0
                for style, _, count in _PARAM_STYLES:
                    ax.plot(t, values[:, 10 * i + first:10 * i + first + count], style, color=colour, lw=0.6)
                    first += count
                handles.append(Line2D([], [], color=colour, lw=1.5, label=joint))
        if handles:
            handles += [Line2D([], [], color="0.3", ls=style, lw=1.0, label=label) for style, label, _ in _PARAM_STYLES]
            ax.legend(handles=handles, fontsize=6, ncol=3, loc="best")
        elif ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=6, ncol=3, loc="best")
        ax.set_title("adaptive estimates: " + ", ".join(names))
        ax.set_ylabel("estimate (SI units)")
    return draw


def _gait_phases(t, tel):
    def draw(ax):
        ax.step(t, _columns(tel, "leg_state")[:, 0], where="post", lw=1.2, color="k", label="state")
        if "leg_gates" in tel:
            gates = _columns(tel, "leg_gates")
            names = tel.meta.get("leg_gates_labels") or [f"g{k}" for k in range(gates.shape[1])]
            for k in range(gates.shape[1]):  # one thin band per gate below the states
                ax.fill_between(t, -0.9 - 0.6 * k, -0.9 - 0.6 * k + 0.45 * gates[:, k], step="post", lw=0)
                ax.text(t[0], -0.75 - 0.6 * k, names[k], fontsize=5, va="center")
        ax.set_title("gait phases: automaton state (and gate bits below)")
        ax.set_ylabel("state")
    return draw


def _leg_actions(t, tel):
    def draw(ax):
        actions = _columns(tel, "leg_actions")
        ax.step(t, actions[:, 0], where="post", lw=0.8, label="knee")
        ax.step(t, actions[:, 1] + 0.05, where="post", lw=0.8, label="ankle")
        if "leg_channels" in tel:
            loads = _columns(tel, "leg_channels")[:, 3:5]
            ax.plot(t, np.clip(loads, 0, 3), lw=0.5, alpha=0.6)
        ax.set_yticks([0, 1, 2, 3], ["hold", "decrease", "increase", "release"])
        ax.set_title("actions (knee, ankle) and foot loads (toe, heel)")
        ax.legend(fontsize=6, loc="best")
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
        panels.append(lambda ax: _per_joint(ax, t, error, "tracking error q_des − q", "rad", _joint_names(tel, error.shape[1])))
    if "tau" in tel:
        tau = _columns(tel, "tau")
        panels.append(lambda ax: _per_joint(ax, t, tau, "torque", "N·m", _joint_names(tel, tau.shape[1])))
    timing = [name for name in tel.columns if name.endswith("_ns")]
    if timing:
        panels.append(_timing(tel, timing))
    if "s" in tel:
        s = _columns(tel, "s")
        panels.append(lambda ax: _per_joint(ax, t, s, "sliding variable s", "rad/s", _joint_names(tel, s.shape[1])))
    if "leg_state" in tel:
        panels.append(_gait_phases(t, tel))
    if "leg_actions" in tel:
        panels.append(_leg_actions(t, tel))
    if "marker_measured_px" in tel and "marker_predicted_px" in tel:
        panels += [_marker(t, tel), _marker_error(t, tel)]
    estimates = [name for name in tel.columns if name.startswith(ESTIMATE_PREFIXES)]
    if estimates:
        panels.append(_estimates(t, tel, estimates))
    panels += _arma_panels(t, tel)
    return panels


def _arma_panels(t, tel):
    panels = []
    for name, symbol in (("a_hat", "â"), ("b_hat", "b̂")):
        if name in tel and tel[name].ndim == 3:
            first = 1 if name == "a_hat" else 0
            for k in range(tel[name].shape[1]):
                panels.append(lambda ax, v=tel[name][:, k, :], title=f"{symbol}{first + k}":
                              _per_joint(ax, t, v, title, "", _joint_names(tel, v.shape[1])))
    for name, (title, unit) in ARMA_PANELS.items():
        if name in tel and "b_hat" in tel:
            panels.append(lambda ax, v=_columns(tel, name), title=title, unit=unit:
                          _per_joint(ax, t, v, title, unit, _joint_names(tel, v.shape[1])))
    return panels


def plot_run(path, out_png, columns: int = 3, option: str = "--output") -> Path:
    """Draw the telemetry file ``path`` into ``out_png`` (PNG, or PDF/SVG by its suffix; a name
    without one gets .png; its folder is created); returns the path written."""
    from rtctl.outputs import output_path

    out = output_path(out_png, option, suffixes=(".png", ".pdf", ".svg"), default_suffix=".png")
    fig = figure(path, columns)
    fig.savefig(out, dpi=90)
    return out


def figure(path, columns: int = 3):
    """The matplotlib Figure ``plot_run`` saves."""
    Figure = _figure_class()
    tel = read(path)
    tel.require_rows("plot")
    panels = _panels(tel)
    if not panels:
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
                 + (f" ({tel.incomplete})" if tel.incomplete else ""))
    return fig
