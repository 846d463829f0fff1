"""Issue 10 over the wire: the ARMA/GMV job through `rtctl run` against `hil-sim` in its own
process over socketcand (three MIT drives, 500 Hz, controller every 10th tick): to the paper's
start pose, the paper's move, the hold. Measured on this VM: see the printed line."""
import numpy as np
import pytest

from hil_helpers import STALL_TOLERANT, run, variant

pytestmark = pytest.mark.hil


def test_arma_gmv_runs_the_paper_move_over_socketcand(tmp_path, hil_sim):
    config = variant(tmp_path, "puma3_arma_gmv_hil_socketcand.toml", **STALL_TOLERANT)
    sim = hil_sim(config, "--port", 0)
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=5.5)
    sim_exit = sim.stop()
    assert code == 0, (summary["stop_reason"], summary["safety"]["faults"][:3])
    assert telemetry.rows == summary["timing"]["ticks"]
    assert not any(d["enabled"] for d in sim_exit["drives"])
    tracking = summary["tracking_error_rad"]
    q_end, goal = telemetry["q"][-1], np.radians([135.0, 90.0, -45.0])
    t = telemetry["t"]
    hold = np.median(telemetry["q"][t > t[-1] - 1.5], axis=0)  # the hold's last 1.5 s (the move ends at 3 s)
    print(f"ARMA/GMV over socketcand: hold {np.degrees(hold - goal).round(3)}°, max {np.degrees(tracking['max_all']):.2f}°, "
          f"rms {np.degrees(tracking['rms_all']):.3f}°, final error {np.degrees(q_end - goal).round(3)}°, "
          f"overruns {summary['timing']['overruns']}")
    for name in ("a_hat", "b_hat", "r_hat", "u"):
        assert np.all(np.isfinite(telemetry[name]))
    # it got there and held: the median of the last 1.5 s of the hold. Until 2026-12-02 the
    # controller rang around the goal (up to 7° peak to peak) in some runs — the MIT driver's late
    # replies left the measurement a period or two older after a stall (docs/can_joints.md) — and
    # over the last 0.5 s the median was off by up to 2.2°; over 1.5 s by at most 0.20° in 20 runs:
    # the bound is 3× that. Since the fix: within 0.03° in 11 runs, ringing ≤ 1.2° peak to peak
    assert np.all(np.abs(np.degrees(hold - goal)) < 0.6), np.degrees(hold - goal)
