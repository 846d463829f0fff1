"""Issue 5 over the wire: the C* Slotine–Li controller, from zero parameter estimates, runs
through `rtctl run` against `hil-sim` in its own process over socketcand (PUMA 560, 6 MIT drives,
500 Hz): a clean run, every tick recorded, no drive left enabled, estimates adapting and finite.

Tracking is printed, not bounded, because over the wire it is not reliable yet. The same run gave
max |e| 0.044–0.047 rad in most runs, and 0.26–1.6 rad (torque-saturated oscillation) in others,
with as few as 6 overruns and a 35 µs wake-lateness p99. So the cause is not machine stalls: it is
the law's marginal stability against the wire's one-period delay (two periods when a reply misses
its deadline). The adaptation gains of configs/puma560_cstar_sim.toml (P = 20/20/5) diverge every
time, even from the true parameters and without the motor-model feed-forward, so the 10× lower
gains below are used. Halving K_D, or dropping the motor model, did not make it reliable. Open:
choosing Λ, K_D and P with the delay in mind."""
import numpy as np
import pytest

from hil_helpers import run, unless_stalled, variant

pytestmark = pytest.mark.hil

CSTAR = """[[controllers]]
name = "adaptive"
type = "slotine_li"
law = "cstar"
lam = 5.0
kd = [40.0, 80.0, 20.0, 5.0, 5.0, 5.0]
gamma = { mass = 2.0, first_moment = 2.0, inertia = 0.5 }
params0 = "zeros"
projection = true
motor_model = true
dead_zone = 0.05
"""


def test_cstar_from_zero_estimates_runs_over_socketcand(tmp_path, hil_sim):
    config = variant(tmp_path, "puma560_hil_socketcand.toml", drive_timeout=0.1, stale_limit=10, stale_ticks=10)
    text = config.read_text()
    start = text.index("[[controllers]]")
    config.write_text(text[:start] + CSTAR + "\n" + text[text.index("[trajectory]"):])
    sim = hil_sim(config, "--port", 0, "--drive-timeout-ms", 100)
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=4.0)
    sim_exit = sim.stop()
    with unless_stalled(summary):
        assert code == 0, (summary["stop_reason"], summary["safety"]["faults"][:3])
    assert telemetry.rows == summary["timing"]["ticks"]
    assert not any(d["enabled"] for d in sim_exit["drives"])
    tracking = summary["tracking_error_rad"]
    print(f"C* over socketcand: max {tracking['max_all']:.4f} rad, rms {tracking['rms_all']:.4f} rad, "
          f"overruns {summary['timing']['overruns']}")
    params = telemetry["params_hat"]
    assert np.all(np.isfinite(params)) and np.abs(params).max() < 100.0
    assert np.abs(params[-1]).max() > 0.1  # the estimates moved away from zero: it adapted
