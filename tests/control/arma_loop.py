"""The shipped ARMA/GMV job in-process: its controller (from configs/puma3_arma_gmv_sim.toml,
options overridable) against hil_sim's plant as the embedded simulator plays it (RK4 at 1 ms,
torque held between controller updates), without the daemon around it."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from hil_sim.plant import Plant
from rtctl.config import load_config
from rtctl.control.base import Reference
from rtctl.hal.joints import JointCommand, JointState
from rtctl.runtime import build
from rtctl.trajectory import JointLimits, through_waypoints

SHIPPED = Path(__file__).resolve().parents[2] / "configs" / "puma3_arma_gmv_sim.toml"


def replaced(text, options):
    """The shipped TOML ``text`` with the (possibly multi-line) values of ``options``' keys
    replaced, its robot description made absolute (the copy lives elsewhere)."""
    lines, skip = [], 0
    for line in text.splitlines():
        code = line.split("#", 1)[0]
        if skip:  # inside a replaced multi-line array
            skip += code.count("[") - code.count("]")
            continue
        key = code.split("=", 1)[0].strip()
        if key in options and "=" in code:
            lines.append(f"{key} = {options[key]}")
            skip = code.count("[") - code.count("]")
        else:
            lines.append(line)
    return "\n".join(lines).replace('description = "robots/', f'description = "{SHIPPED.parent}/robots/')


def shipped(tmp_path=None, **options):
    """(config, controller) of the shipped job; ``options`` replace ``key = value`` lines."""
    path = SHIPPED
    if options:
        path = tmp_path / "run.toml"
        path.write_text(replaced(SHIPPED.read_text(), options))
    cfg = load_config(path)
    return cfg, build(cfg).controllers[0]


def run(cfg, controller, seconds=3.0, friction=0.0):
    """Per tick: t, q, q_des, the command, and the filter's R̂ and largest Q̂ entry per joint;
    the controller every ``divisor`` ticks."""
    model = cfg.model
    n, dt = model.nq, cfg.loop.period
    q0 = cfg.sim.vector("initial_q", n)
    plant = Plant(model, substeps=1, integrator="rk4", friction_scale=friction, q0=q0)
    tcfg = cfg.trajectory
    limits = JointLimits(np.full(n, 10.0), tcfg.max_acceleration, model.q_min, model.q_max)
    trajectory = through_waypoints(tcfg.waypoints, limits, start=q0, durations=tcfg.durations)
    state, ref, cmd = JointState(n), Reference(n), JointCommand(n)
    state.position[:] = plant.q
    controller.reset(state)
    steps = int(round(seconds / dt))
    log = {"t": np.arange(steps) * dt, "q": np.zeros((steps, n)), "q_des": np.zeros((steps, n)),
           "tau": np.zeros((steps, n)), "R_hat": np.zeros((steps, n)), "Q_hat": np.zeros((steps, n))}
    f = controller.filter
    for k in range(steps):
        t = k * dt
        state.position[:], state.velocity[:] = plant.q, plant.qd
        trajectory.sample(t, ref.q, ref.qd, ref.qdd)
        if k % controller.divisor == 0:
            controller.update(t, state, ref, cmd)
        log["q"][k], log["q_des"][k], log["tau"][k] = plant.q, ref.q, cmd.tau_ff
        log["R_hat"][k], log["Q_hat"][k] = f.R_hat, f.Q_hat.max(axis=0)
        plant.tau_cmd[:] = cmd.tau_ff
        plant.step(dt)
    return log
