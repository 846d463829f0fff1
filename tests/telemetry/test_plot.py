"""rtctl.plot draws a readable PNG from a telemetry file, and says what to install without matplotlib."""
import sys

import numpy as np
import pytest

from rtctl.errors import RtctlError
from rtctl.telemetry import Recorder

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def synthetic_run(path, schema_extra=(), n=1500):
    """A 6-joint run: q lags a sinusoidal q_des, estimates converge, timings are log-normal."""
    schema = {"t": ((), "f8"), "q": (6, "f8"), "q_des": (6, "f8"), "tau": (6, "f8"), **dict(schema_extra)}
    rng = np.random.default_rng(0)
    rec = Recorder(path, schema, {"config": "configs/puma560_sim.toml", "rate_hz": 1000.0}, wait_when_full=True)
    phase = np.arange(6)
    for k in range(n):
        t = k / 1000
        rec.row["t"][()] = t
        rec.row["q_des"][:] = np.sin(2 * t + phase)
        rec.row["q"][:] = np.sin(2 * (t - 0.02) + phase)
        rec.row["tau"][:] = 10 * np.cos(2 * t + phase)
        if "phase_ns" in schema:
            rec.row["phase_ns"][:] = rng.lognormal(np.log([3e3, 20e3, 2e3, 3e3, 1e3]), 0.3)
            rec.row["lateness_ns"][()] = rng.lognormal(np.log(10e3), 0.5)
            rec.row["params_hat"][:] = np.exp(-t) * np.linspace(-1, 1, 10) + 1
            rec.row["s"][:] = 0.1 * np.exp(-t) * np.cos(t + phase)
        rec.commit()
    rec.close()


FULL = {"phase_ns": (5, "i8"), "lateness_ns": ((), "i8"), "params_hat": (10, "f8"), "s": (6, "f8")}


def test_plot_run_writes_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    from rtctl.plot import _panels, plot_run
    from rtctl.telemetry import read

    synthetic_run(tmp_path / "run.rtt", FULL.items())
    plot_run(tmp_path / "run.rtt", tmp_path / "run.png")
    data = (tmp_path / "run.png").read_bytes()
    assert data.startswith(PNG_SIGNATURE) and len(data) > 50_000
    # 6 tracking + error + torque + timing + s + estimates
    assert len(_panels(read(tmp_path / "run.rtt"))) == 11


def test_every_panel_says_what_it_shows(tmp_path):
    pytest.importorskip("matplotlib")
    from rtctl.plot import figure

    joints = ["waist", "shoulder", "elbow"]
    schema = {"t": ((), "f8"), "q": (3, "f8"), "phase_ns": (5, "i8"), "params_hat": (30, "f8")}
    rec = Recorder(tmp_path / "run.rtt", schema, {"joints": joints, "rate_hz": 1000.0}, wait_when_full=True)
    for k in range(200):
        rec.row["t"][()] = k / 1000
        rec.row["q"][:] = k
        rec.row["phase_ns"][:] = 1000 + k
        rec.row["params_hat"][:] = np.arange(30) * k
        rec.commit()
    rec.close()
    axes = figure(tmp_path / "run.rtt").axes
    assert all(ax.get_ylabel() and ax.get_xlabel() for ax in axes), [ax.get_title() for ax in axes]
    timing = next(ax for ax in axes if ax.get_title() == "timing per tick")
    assert timing.get_ylabel() == "ticks"
    estimates = next(ax for ax in axes if ax.get_title().startswith("adaptive estimates"))
    legend = [text.get_text() for text in estimates.get_legend().get_texts()]
    assert legend == joints + ["m (kg)", "m·c (kg·m)", "J (kg·m²)"]
    assert len(estimates.get_lines()) == 30  # one line per parameter
    # each link's 10 lines share its colour
    colours = [line.get_color() for line in estimates.get_lines()]
    assert [len(set(colours[10 * i:10 * i + 10])) for i in range(3)] == [1, 1, 1] and len(set(colours)) == 3


def test_plot_run_with_only_positions(tmp_path):
    pytest.importorskip("matplotlib")
    from rtctl.plot import plot_run

    rec = Recorder(tmp_path / "run.rtt", {"q": ((), "f8")}, wait_when_full=True)
    for k in range(100):
        rec.row["q"][()] = k
        rec.commit()
    rec.close()
    plot_run(tmp_path / "run.rtt", tmp_path / "run.png")
    assert (tmp_path / "run.png").read_bytes().startswith(PNG_SIGNATURE)


def test_missing_matplotlib_says_what_to_install(tmp_path, monkeypatch):
    from rtctl.plot import plot_run

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(RtctlError, match=r"pip install -e '\.\[plot\]'"):
        plot_run(tmp_path / "run.rtt", tmp_path / "run.png")


def test_the_panels_draw_the_recorded_data(tmp_path):
    """Each line is the telemetry column it claims to be, against the recorded time."""
    pytest.importorskip("matplotlib")
    from rtctl.plot import figure
    from rtctl.telemetry import read

    synthetic_run(tmp_path / "run.rtt", FULL.items(), n=300)
    tel = read(tmp_path / "run.rtt")
    axes = {ax.get_title(): ax for ax in figure(tmp_path / "run.rtt").axes}
    for j in range(6):
        lines = {line.get_label(): line for line in axes[f"joint {j + 1}: j{j + 1}"].get_lines()}
        np.testing.assert_array_equal(lines["q"].get_xdata(), tel["t"])
        np.testing.assert_array_equal(lines["q"].get_ydata(), tel["q"][:, j])
        np.testing.assert_array_equal(lines["q_des"].get_ydata(), tel["q_des"][:, j])
    error = axes["tracking error q_des − q"].get_lines()
    np.testing.assert_allclose(np.column_stack([line.get_ydata() for line in error]), tel["q_des"] - tel["q"])
    torque = axes["torque"].get_lines()
    np.testing.assert_array_equal(np.column_stack([line.get_ydata() for line in torque]), tel["tau"])
    s = axes["sliding variable s"].get_lines()
    np.testing.assert_array_equal(np.column_stack([line.get_ydata() for line in s]), tel["s"])
    estimates = next(ax for title, ax in axes.items() if title.startswith("adaptive estimates")).get_lines()
    np.testing.assert_array_equal(np.column_stack([line.get_ydata() for line in estimates]), tel["params_hat"])


def test_the_gait_panels_draw_the_leg_automaton(tmp_path):
    """A leg run: the automaton's state as a step line with one band per gate below it, and the
    knee and ankle actions against the foot loads."""
    pytest.importorskip("matplotlib")
    from rtctl.plot import figure
    from rtctl.telemetry import read

    gates = ["h_f", "h_e", "k_f", "k_e", "toe", "heel", "h_d1", "h_d2"]
    schema = {"t": ((), "f8"), "leg_state": (1, "f8"), "leg_gates": (8, "u1"), "leg_actions": (2, "u1"),
              "leg_channels": (5, "f8")}
    rec = Recorder(tmp_path / "leg.rtt", schema, {"leg_gates_labels": gates}, wait_when_full=True)
    cycle = [1, 2, 3, 4, 1, 5, 1, 6]
    for k in range(400):
        rec.row["t"][()] = k / 100
        rec.row["leg_state"][:] = cycle[(k // 10) % 8]
        rec.row["leg_gates"][:] = [(k >> b) & 1 for b in range(8)]
        rec.row["leg_actions"][:] = [k % 4, (k // 4) % 4]
        rec.row["leg_channels"][:] = [0.0, 0.0, 0.0, 1.0, 0.5]
        rec.commit()
    rec.close()
    tel = read(tmp_path / "leg.rtt")
    axes = {ax.get_title(): ax for ax in figure(tmp_path / "leg.rtt").axes}
    gait = axes["gait phases: automaton state (and gate bits below)"]
    (state,) = gait.get_lines()
    np.testing.assert_array_equal(state.get_ydata(), tel["leg_state"][:, 0])
    assert len(gait.collections) == 8 and [t.get_text() for t in gait.texts] == gates  # a band per gate
    actions = axes["actions (knee, ankle) and foot loads (toe, heel)"]
    knee, ankle = actions.get_lines()[:2]
    np.testing.assert_array_equal(knee.get_ydata(), tel["leg_actions"][:, 0])
    np.testing.assert_allclose(ankle.get_ydata(), tel["leg_actions"][:, 1] + 0.05)
