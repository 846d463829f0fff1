"""Issue 10 over the wire: the ARMA/GMV job through `rtctl run` against `hil-sim` in its own
process over socketcand (three MIT drives, 500 Hz, controller every 10th tick): to the paper's
start pose, the paper's move, the hold. Measured on this VM: see the printed line."""
import numpy as np
import pytest

from hil_helpers import run, variant

pytestmark = pytest.mark.hil


def test_arma_gmv_runs_the_paper_move_over_socketcand(tmp_path, hil_sim):
    config = variant(tmp_path, "puma3_arma_gmv_hil_socketcand.toml", drive_timeout=0.1, stale_limit=10,
                     stale_ticks=10)
    sim = hil_sim(config, "--port", 0, "--drive-timeout-ms", 100)
    code, summary, telemetry, err = run(config, tmp_path, sim.env(), duration=5.5)
    sim_exit = sim.stop()
    assert code == 0, (summary["stop_reason"], summary["safety"]["faults"][:3])
    assert telemetry.rows == summary["timing"]["ticks"]
    assert not any(d["enabled"] for d in sim_exit["drives"])
    tracking = summary["tracking_error_rad"]
    q_end, goal = telemetry["q"][-1], np.radians([135.0, 90.0, -45.0])
    print(f"ARMA/GMV over socketcand: max {np.degrees(tracking['max_all']):.2f}°, "
          f"rms {np.degrees(tracking['rms_all']):.3f}°, final error {np.degrees(q_end - goal).round(3)}°, "
          f"overruns {summary['timing']['overruns']}")
    for name in ("a_hat", "b_hat", "r_hat", "u"):
        assert np.all(np.isfinite(telemetry[name]))
    # it got there and held: the median of the last 0.5 s (250 ticks). On this VM every run overruns
    # 20–210 times (ms-late wake-ups at 500 Hz) and the 50 Hz controller then rings for a while —
    # the last sample was up to 3.2° off in 2 of 12 runs (2026-12-01) — while the hold's median was
    # within 0.23° in all 12: the bound is 3× that
    hold = np.median(telemetry["q"][-250:], axis=0)
    assert np.all(np.abs(np.degrees(hold - goal)) < 0.7), np.degrees(hold - goal)
