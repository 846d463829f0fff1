#!/usr/bin/env python3
"""The ARMA/GMV studies of docs/arma_kalman.md, rerunnable by anyone:

    python scripts/arma_gmv_study.py compare   # ARMA/GMV vs C* Slotine–Li, computed torque, PD + gravity
    python scripts/arma_gmv_study.py sweep     # λ × ρ × θ̂(0), and the range of good initial b̂
    python scripts/arma_gmv_study.py all --out docs    # both; tables (Markdown, JSON) and docs/img/*.png

Every case is the shipped job configs/puma3_arma_gmv_sim.toml (the paper's move on the three-joint
PUMA, plant by RK4 at 1 ms) with its controller replaced or its options changed, run in-process:
the controller from the configuration as `rtctl run` builds it, the embedded simulator's plant,
the reference every tick, the controller at its rate divisor with the torque held in between.
Deterministic (no noise): the numbers are reproducible to the last digit on one machine.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hil_sim.plant import Plant  # noqa: E402
from rtctl.config import load_config  # noqa: E402
from rtctl.control.base import Reference  # noqa: E402
from rtctl.control.gmv import gmv_law, gmv_phi  # noqa: E402
from rtctl.errors import ControllerError  # noqa: E402
from rtctl.estimation.arx import push_history, regressor_into  # noqa: E402
from rtctl.estimation.printed import PrintedSageHusa  # noqa: E402
from rtctl.estimation.sage_husa import SWITCH_NAMES  # noqa: E402
from rtctl.hal.joints import JointCommand, JointState  # noqa: E402
from rtctl.jsonout import dumps  # noqa: E402
from rtctl.model.dynamics import gravity  # noqa: E402
from rtctl.runtime import build  # noqa: E402
from rtctl.trajectory import JointLimits, through_waypoints  # noqa: E402

SHIPPED = ROOT / "configs" / "puma3_arma_gmv_sim.toml"
SECONDS, MOVE_END, SETTLE = 3.0, 1.0, 1.5
HOLD = 1.5  # s: the hold's ringing is measured from 0.5 s after the move to the end
STEP_MIN = 0.1  # N·m: torque steps smaller than this are not counted as alternating
B0 = np.array([1.03e-4, 5.784e-5, 3.498e-4])  # the shipped θ̂(0)'s b0 per joint: T²/(2 J_min/1.2)
# the job shipped before issue 29: r̂ alone adapted, θ̂(0) from J_min (b0 = B0/1.2), ρ = 0.1 b0²
BEFORE = {"adapt": "{ r = true, R = false, q = false, Q = false }", "noise_form": '"sage_husa"',
          "theta0": "[[2.0, -1.0, 8.58e-5, 8.58e-5, 0.0], [2.0, -1.0, 4.82e-5, 4.82e-5, 0.0], "
                    "[2.0, -1.0, 2.915e-4, 2.915e-4, 0.0]]",
          "P0": "[[1e-6, 1e-6, 2.9e-12, 2.9e-12, 2.9e-12], [1e-6, 1e-6, 9.3e-13, 9.3e-13, 9.3e-13], "
                "[1e-6, 1e-6, 3.4e-11, 3.4e-11, 3.4e-11]]",
          "rho": "[7.4e-10, 2.3e-10, 8.5e-9]"}
OTHERS = {
    "C* Slotine–Li (1 kHz, π̂(0) = 0)": '''type = "slotine_li"
law = "cstar"
lam = 5.0
kd = [40.0, 80.0, 20.0]
gamma = { mass = 20.0, first_moment = 20.0, inertia = 5.0 }
params0 = "zeros"
projection = true
motor_model = true''',
    "computed torque, true model (1 kHz)": 'type = "computed_torque"\nkp = 400.0\nkd = 40.0',
    "computed torque, true model (50 Hz)": 'type = "computed_torque"\ndivisor = 20\nkp = 400.0\nkd = 40.0',
    "PD + gravity (1 kHz)": 'type = "pd_gravity"\nkp = [1200.0, 1700.0, 280.0]\nkd = [120.0, 170.0, 28.0]',
}


def _variant(options: dict | None = None, controller: str | None = None) -> Path:
    """The shipped config with ``key = value`` lines replaced, or its [[controllers]] body replaced."""
    text = SHIPPED.read_text().replace('description = "robots/', f'description = "{SHIPPED.parent}/robots/')
    if controller is not None:
        head, rest = text.split("[[controllers]]", 1)
        text = head + '[[controllers]]\nname = "c"\n' + controller + "\n\n" + rest[rest.index("[trajectory]"):]
    lines, skip = [], 0
    for line in text.splitlines():
        code = line.split("#", 1)[0]
        if skip:
            skip += code.count("[") - code.count("]")
            continue
        key = code.split("=", 1)[0].strip()
        if options and key in options and "=" in code:
            lines.append(f"{key} = {options[key]}")
            skip = code.count("[") - code.count("]")
        else:
            lines.append(line)
    path = Path(tempfile.mkdtemp()) / "case.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def simulate(config: Path, friction: float | None = None, printed: bool = False, filtered: str = "") -> dict:
    """The job in ``config`` for SECONDS; ``printed``, ``filtered``: see :class:`PythonLoopGmv`."""
    cfg = load_config(config)
    model, (controller,) = cfg.model, build(cfg).controllers
    if printed or filtered:
        controller = PythonLoopGmv(controller, printed, filtered)
    if friction is None and cfg.sim.float("friction", 0.0) == 0.0:
        _no_friction_feedforward(controller)
    n, dt = model.nq, cfg.loop.period
    q0 = cfg.sim.vector("initial_q", n)
    plant = Plant(model, substeps=1, integrator="rk4", q0=q0,
                  friction_scale=cfg.sim.float("friction", 0.0) if friction is None else friction)
    tc = cfg.trajectory
    traj = through_waypoints(tc.waypoints, JointLimits(np.full(n, 10.0), tc.max_acceleration, model.q_min, model.q_max),
                             start=q0, durations=tc.durations)
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:] = plant.q
    controller.reset(state)
    steps = int(round(SECONDS / dt))
    log = {k: np.full((steps, n), np.nan) for k in ("q", "q_des", "tau")}
    log["t"], log["r_hat"], log["fault"] = np.arange(steps) * dt, np.full((steps, n), np.nan), None
    for k in range(steps):
        t = k * dt
        state.position[:], state.velocity[:] = plant.q, plant.qd
        traj.sample(t, ref.q, ref.qd, ref.qdd)
        if k % controller.divisor == 0:
            try:
                controller.update(t, state, ref, cmd)
            except ControllerError as e:
                log["fault"] = f"{t:.2f} s: {e}"
                break
        np.clip(cmd.tau_ff, -model.tau_max, model.tau_max, out=cmd.tau_ff)  # what the safety stage bounds
        log["q"][k], log["q_des"][k], log["tau"][k] = plant.q, ref.q, cmd.tau_ff
        if "r_hat" in controller.internals:
            log["r_hat"][k] = controller.internals["r_hat"]
        if np.any(np.abs(plant.q - ref.q) > np.pi):  # the arm ran away: the safety stage would stop it
            log["fault"] = f"{t:.2f} s: error above 180°"
            break
        plant.tau_cmd[:] = cmd.tau_ff
        plant.step(dt)
    log["model"], log["tau_max"] = model, model.tau_max
    if printed or filtered:
        log["R_low"] = controller.R_low
    return log


class PythonLoopGmv:
    """An arma_gmv controller's update written out in Python (slow), for two departures from it:
    ``printed``: the filter is :class:`~rtctl.estimation.printed.PrintedSageHusa` (the equations
    without safeguards); ``filtered``: GMV's predictor (28) reads the filtered output
    ŷ(k|k) = hᵀθ̂(k|k) + r̂ instead of the measured y — for y(k) alone ("current") or for the
    past outputs too ("all"; the filter's regressor keeps the measured ones)."""

    def __init__(self, controller, printed: bool = False, filtered: str = ""):
        self.c, self.divisor, self.internals = controller, controller.divisor, controller.internals
        self.printed, self.filtered = printed, filtered

    def reset(self, state) -> None:
        c = self.c
        c.reset(state)
        f = c.filter
        adapt = [name for name, on in zip(SWITCH_NAMES, f.switches) if on]
        self.filters = [PrintedSageHusa(f.p, lam=f.lam, theta0=f.theta0[:, i], P0=np.diag(f.P0[i]), r0=f.r0[i],
                                        R0=f.R0[i], Q0=f.Q0[:, i], adapt=adapt) for i in range(f.m)]
        self.R_low = [np.inf] * f.m  # the lowest R̂ each joint's filter reached
        self.yf_hist = c.y_hist.copy()  # the filtered outputs ŷ(k−1|k−1) … for "all"
        self.t_prev = None

    def update(self, t, state, ref, cmd) -> None:
        c, o, f = self.c, self.c.order, self.c.filter
        theta, signals = f.theta, f.signals
        tau_h = 0.0 if self.t_prev is None else o.d * (t - self.t_prev)
        h, y_pred = np.zeros(o.p), np.zeros(o.d)
        for i, j in enumerate(c.joints):
            y = y_gmv = state.position[j]
            if self.t_prev is not None:
                regressor_into(i, c.y_hist, c.u_hist, o.d, h)
                r_used = signals[0, i]
                if self.printed:
                    flt = self.filters[i]
                    flt.update(h, y)
                    theta[:, i], signals[0, i], signals[1, i] = flt.theta, flt.r, flt.R
                else:
                    f.update(i, h, y)
                self.R_low[i] = min(self.R_low[i], signals[1, i])
                if self.filtered:
                    y_gmv = float(h @ theta[:, i]) + r_used
            y_star = ref.q[j] + ref.qd[j] * tau_h + 0.5 * ref.qdd[j] * tau_h ** 2
            past = self.yf_hist if self.filtered == "all" else c.y_hist
            phi = gmv_phi(i, theta, signals[0, i], y_gmv, past, c.u_hist, o.na, o.d, y_pred)
            u = gmv_law(theta[o.na, i], phi, y_star, c.joint_params[0, i], c.u_hist[0, i], c.joint_params[1, i])
            if not (np.isfinite(u) and np.all(np.isfinite(theta[:, i]))):
                raise ControllerError(f"joint {i}: non-finite estimate or torque (R̂ = {signals[1, i]:.3g})")
            self.yf_hist[1:, i] = self.yf_hist[:-1, i]
            self.yf_hist[0, i] = y_gmv
            push_history(i, c.y_hist, c.u_hist, y, u)
            cmd.tau_ff[j] = u
        self.t_prev = t


def _no_friction_feedforward(controller) -> None:
    """The model-based laws' motor model is the robot file's armature *and* friction; the paper's
    plant has no friction, so their "true model" keeps the armature and drops the friction."""
    from rtctl.control import computed_torque, slotine_li_kernels

    if isinstance(controller, computed_torque.ComputedTorque):
        controller.gains[computed_torque.VISCOUS] = controller.gains[computed_torque.COULOMB] = 0.0
    if hasattr(controller, "gains") and getattr(controller, "motor_model", False):  # Slotine–Li
        controller.gains[slotine_li_kernels.VISCOUS] = controller.gains[slotine_li_kernels.COULOMB] = 0.0


def metrics(log: dict) -> dict:
    t, e = log["t"], np.degrees(log["q"] - log["q_des"])
    move, after = t <= MOVE_END, np.argmin(np.abs(t - SETTLE))
    hold = t > MOVE_END
    tau = log["tau"]
    out = {"rms_move_deg": np.sqrt(np.nanmean(e[move] ** 2, axis=0)).tolist(),
           "err_settle_deg": np.abs(e[after]).tolist(),
           "max_hold_deg": np.nanmax(np.abs(e[hold]), axis=0).tolist() if np.any(np.isfinite(e[hold])) else None,
           "peak_tau_pct": (100 * np.nanmax(np.abs(tau), axis=0) / log["tau_max"]).tolist(),
           **ringing(t, tau), "fault": log["fault"]}
    if "R_low" in log:
        out["lowest_R_hat"] = log["R_low"]
    last = np.flatnonzero(np.isfinite(tau[:, 0]))[-1]
    G = gravity(log["model"], log["q"][last])
    out["tau_end"], out["gravity_end"] = tau[last].tolist(), G.tolist()
    return out


def ringing(t, tau, every: int = 20) -> dict:
    """The hold's torque (t ≥ HOLD), one value per 20 ms controller sample: peak to peak, and the
    fraction of consecutive steps Δu(k), Δu(k−1) of opposite signs, each at least STEP_MIN —
    ≈ 1 for a torque ringing at the sample rate, 0 for one that settles."""
    u = tau[::every][(t[::every] >= HOLD) & np.isfinite(tau[::every, 0])]
    if len(u) < 3:
        return {"hold_tau_pp": None, "hold_alternation": None}
    du = np.diff(u, axis=0)
    flips = (du[1:] * du[:-1] < 0) & (np.abs(du[1:]) >= STEP_MIN) & (np.abs(du[:-1]) >= STEP_MIN)
    return {"hold_tau_pp": np.ptp(u, axis=0).tolist(), "hold_alternation": flips.mean(axis=0).tolist()}


def verdict(m: dict) -> str:
    if m["fault"]:
        return "fails: " + m["fault"]
    if max(m["max_hold_deg"]) > 2.0 or max(m["hold_tau_pp"]) > 20.0:
        return "oscillates in the hold"
    if any(a >= 0.5 and pp >= 1.0 for a, pp in zip(m["hold_alternation"], m["hold_tau_pp"])):
        return "rings in the hold"
    if max(m["peak_tau_pct"]) >= 99.9:
        return "works, torque saturates"
    return "works"


def _fmt(values, digits=2):
    return " / ".join(f"{v:.{digits}f}" for v in values)


def compare(out: Path) -> list[dict]:
    rows = [{"controller": "ARMA/GMV (paper, 50 Hz)", **metrics(arma := simulate(SHIPPED))}]
    logs = {"ARMA/GMV (paper, 50 Hz)": arma}
    cases = {BEFORE_NAME: _variant(BEFORE), **{name: _variant(controller=body) for name, body in OTHERS.items()}}
    for name, config in cases.items():
        logs[name] = log = simulate(config)
        rows.append({"controller": name, **metrics(log)})
    table = ["| controller | RMS error during the move (°), waist / shoulder / elbow | error 0.5 s after (°) | "
             "peak torque (% of limit) | hold: torque peak to peak (N·m), alternating steps |", "|---|---|---|---|---|"]
    for r in rows:
        table.append(f"| {r['controller']} | {_fmt(r['rms_move_deg'], 3)} | {_fmt(r['err_settle_deg'], 4)} | "
                     f"{_fmt(r['peak_tau_pct'], 0)} | {_fmt(r['hold_tau_pp'], 1)}; {_fmt(r['hold_alternation'], 2)} |")
    _write(out, "arma_gmv_comparison", rows, table)
    _plot_comparison(logs, out / "img" / "arma_gmv_comparison.png")
    return rows


BEFORE_NAME = "ARMA/GMV before (r̂ only, θ̂(0) from J_min)"
ADAPT_ALL = "{ r = true, R = true, q = false, Q = true }"
# single changes to the shipped job: the noise statistics' forms and switches
CASES = {
    "printed (19)-(27), no safeguard (r̂, R̂, Q̂ on)": ({}, {"printed": True}),
    "noise_form = sage_husa: (25), diagonal (27), safeguarded": ({"noise_form": '"sage_husa"'}, {}),
    "R̂, Q̂ fixed (r̂ only)": ({"adapt": "{ r = true, R = false, q = false, Q = false }"}, {}),
    "R̂ adapted, Q̂ fixed": ({"adapt": "{ r = true, R = true, q = false, Q = false }"}, {}),
    "θ̂(0), ρ from J_min (b̂0 / 1.2)": ({"theta0": BEFORE["theta0"], "rho": BEFORE["rho"], "P0": BEFORE["P0"]}, {}),
    BEFORE_NAME: (BEFORE, {}),
    "GMV on the filtered output ŷ(k|k)": ({}, {"filtered": "current"}),
    "GMV on filtered outputs ŷ(k|k), ŷ(k−1|k−1)": ({}, {"filtered": "all"}),
    "q̂ adapted too (r̂, R̂, q̂, Q̂ on)": ({"adapt": "{ r = true, R = true, q = true, Q = true }"}, {}),
    "no adaptation at all (P(0) = 0, r̂ off)": (
        {"P0": "0.0", "adapt": "{ r = false, R = false, q = false, Q = false }"}, {}),
}


def sweep(out: Path) -> list[dict]:
    rows = []
    for theta0 in ("good", "poor"):
        for lam in (0.95, 0.98, 0.995):
            for sigma in (0.01, 0.1, 1.0):
                options = {"lam": lam, "rho": _array(sigma * B0 ** 2)}
                if theta0 == "poor":  # every b̂ half the good one: inertia overestimated 2×
                    options["theta0"] = _theta0(0.5)
                m = metrics(simulate(_variant(options)))
                rows.append({"theta0": theta0, "lam": lam, "sigma": sigma, **m, "verdict": verdict(m)})
    for name, (options, how) in CASES.items():
        m = metrics(simulate(_variant(options), **how))
        rows.append({"theta0": "good", "case": name, "lam": 0.98, "sigma": 0.1, **m, "verdict": verdict(m)})
    m = metrics(simulate(SHIPPED, friction=1.0))
    rows.append({"theta0": "good", "case": "drive friction on (viscous + Coulomb)", "lam": 0.98, "sigma": 0.1, **m,
                 "verdict": verdict(m)})
    for scale in (0.5, 0.7, 0.8, 0.9, 1.1, 1.2, 1.3, 1.5, 2.0, 4.0):
        m = metrics(simulate(_variant({"theta0": _theta0(scale)})))
        rows.append({"theta0": f"b̂ × {scale:g}", "lam": 0.98, "sigma": 0.1, **m, "verdict": verdict(m)})
    table = ["| θ̂(0) | case | λ | ρ / b̂0² | RMS move (°) | max error in the hold (°) | peak torque (%) | "
             "hold torque pp (N·m) | verdict |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        hold = _fmt(r["max_hold_deg"], 3) if r["max_hold_deg"] is not None else "—"
        pp = _fmt(r["hold_tau_pp"], 1) if r["hold_tau_pp"] is not None else "—"
        table.append(f"| {r['theta0']} | {r.get('case', '')} | {r['lam']} | {r['sigma']:g} | "
                     f"{_fmt(r['rms_move_deg'], 3)} | {hold} | {_fmt(r['peak_tau_pct'], 0)} | {pp} | {r['verdict']} |")
    _write(out, "arma_gmv_sweep", rows, table)
    return rows


def _theta0(scale: float) -> str:
    return "[" + ", ".join(f"[2.0, -1.0, {b * scale:.4g}, {b * scale:.4g}, 0.0]" for b in B0) + "]"


def _array(values) -> str:
    return "[" + ", ".join(f"{v:.3g}" for v in values) + "]"


def _write(out: Path, name: str, rows, table) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.json").write_text(dumps(rows, indent=1, default=str))
    print("\n".join(table))
    print()


def _plot_comparison(logs: dict, png: Path) -> None:
    from matplotlib.figure import Figure

    png.parent.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(13, 7), layout="constrained")
    names = ("waist", "shoulder", "elbow")
    for j in range(3):
        ax = fig.add_subplot(2, 3, j + 1)
        for label, log in logs.items():
            ax.plot(log["t"], np.degrees(log["q"][:, j] - log["q_des"][:, j]), lw=0.8, label=label)
        ax.set_title(f"{names[j]}: tracking error")
        ax.set_ylabel("deg")
        ax.set_ylim(-1.0, 1.0)
        ax.grid(True, lw=0.3)
        if j == 0:
            ax.legend(fontsize=6)
    arma = logs["ARMA/GMV (paper, 50 Hz)"]
    ax = fig.add_subplot(2, 3, 4)
    for j in range(3):
        ax.plot(arma["t"], arma["tau"][:, j], lw=0.8, label=names[j])
    ax.set_title("ARMA/GMV torque u (held 20 ms)")
    ax.set_ylabel("N·m")
    ax.legend(fontsize=6)
    ax = fig.add_subplot(2, 3, 5)
    for j in range(3):
        ax.plot(arma["t"], arma["r_hat"][:, j] * 1e3, lw=0.8, label=names[j])
    ax.set_title("virtual-noise mean r̂ (mrad per sample)")
    ax.legend(fontsize=6)
    ax = fig.add_subplot(2, 3, 6)
    G = np.array([gravity(arma["model"], q) for q in arma["q"][::20]])
    for j in range(3):
        ax.plot(arma["t"][::20], G[:, j], "--", lw=0.8, label=f"G {names[j]}")
        ax.plot(arma["t"], arma["tau"][:, j], lw=0.6)
    ax.set_xlim(1.0, 3.0)
    ax.set_ylim(-10, 10)
    ax.set_title("after the move: u (solid) → G(q) (dashed)")
    ax.legend(fontsize=6)
    for a in fig.axes:
        a.set_xlabel("t (s)")
    fig.suptitle("The paper's move on the three-joint PUMA: (45°, 0°, −135°) → (135°, 90°, −45°) in 1 s, hold 2 s")
    fig.savefig(png, dpi=80)
    print(f"wrote {png}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("what", choices=("compare", "sweep", "all"))
    p.add_argument("--out", type=Path, default=Path("out/arma_gmv"), help="directory for JSON and img/ (default out/arma_gmv)")
    args = p.parse_args(argv)
    if args.what in ("compare", "all"):
        compare(args.out)
    if args.what in ("sweep", "all"):
        sweep(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
