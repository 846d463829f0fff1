"""Issue 26 item 10: `rtctl identify` on the shipped ARMA/GMV run, with its defaults, agrees
with the controller's own in-loop estimates — and both with the physics: a joint's position
sampled every T under a held torque is the double integrator, a₁ = 2, a₂ = −1.

What was wrong: identify adapted the noise mean r̂ and variance R̂ from θ̂(0) = 0 with
P(0) = 10³·I. On closed-loop data (the GMV torque is a function of the same outputs) the
adapted statistics absorbed the model: waist a₁ = −9.6, a₂ = 10.6, rms ε 0.17–6 rad. The default
is now a least-squares fit (no adaptation); the controller, started from its prior, was right."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from rtctl.telemetry import read

ROOT = Path(__file__).resolve().parents[2]


def test_identify_with_its_defaults_agrees_with_the_in_loop_estimates_on_the_shipped_run(tmp_path):
    run, out = tmp_path / "run.msgpack", tmp_path / "ident.json"
    r = subprocess.run([sys.executable, "-m", "rtctl.cli", "run", str(ROOT / "configs" / "puma3_arma_gmv_sim.toml"),
                        "--realtime-factor", "0", "--duration", "10", "--telemetry", str(run),
                        "--socket", str(tmp_path / "s.sock")], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    r = subprocess.run([sys.executable, "-m", "rtctl.cli", "identify", str(run), "--period", "0.02", "--json", str(out)],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    theta = np.array(json.loads(out.read_text())["theta"])  # (joints, [a1 a2 b0 b1 b2])
    tel = read(run)
    a_loop, b_loop = tel["a_hat"][-2], tel["b_hat"][-2]  # (the last row is the stop's)
    print("identify:", np.round(theta[:, :3], 6).tolist(), "in loop:", np.round(a_loop.T, 4).tolist())
    np.testing.assert_allclose(theta[:, 0], a_loop[0], atol=0.05)
    np.testing.assert_allclose(theta[:, 1], a_loop[1], atol=0.05)
    np.testing.assert_allclose(theta[:, 0] + theta[:, 1], 1.0, atol=0.01)  # the integrator's pole at z = 1
    np.testing.assert_allclose(theta[:, 2], b_loop[0], rtol=0.25)  # b₀ = T²/2J
