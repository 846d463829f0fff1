"""The controller from a run configuration: the shipped C* job, option errors naming the key,
and the job run end to end by the CLI (embedded simulator, telemetry with π̂ and s)."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rtctl.config import load_config
from rtctl.control.slotine_li import SlotineLi
from rtctl.errors import ConfigError
from rtctl.runtime import build
from rtctl.telemetry import read

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "configs" / "puma560_cstar_sim.toml"


def test_shipped_config_builds_the_cstar_controller():
    rt = build(load_config(SHIPPED))
    (c,) = rt.controllers
    assert isinstance(c, SlotineLi) and c.law == "cstar" and c.projection and c.motor_model
    assert not c.params_hat.any()  # starts from zeros
    assert c.gamma[:, 0].tolist() == [2.0] * 6 and c.gamma[:, 9].tolist() == [0.5] * 6


def configured(tmp_path, options: str) -> Path:
    text = SHIPPED.read_text()
    head, _, tail = text.partition('type = "slotine_li"')
    body_end = tail.index("\n[trajectory]")
    text = head + 'type = "slotine_li"\nlam = 5.0\nkd = 10.0\ngamma = 1.0\n' + options + tail[body_end:]
    text = text.replace('description = "robots/puma560.toml"', f'description = "{ROOT / "configs/robots/puma560.toml"}"')
    path = tmp_path / "run.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("options, key", [
    ('law = "fast"', "controllers[0].law"),
    ("lam = [1.0, 2.0]", "controllers[0].lam"),
    ('params0 = "missing.npy"', "controllers[0].params0"),
    ("gains = 3", "controllers[0].gains"),
    ("dead_zone = -1.0", "controllers[0].dead_zone"),
    ("gamma = { mass = 1.0, first_moment = 1.0 }", "controllers[0].gamma.inertia"),
    ("gamma = { mass = 1.0, first_moment = 1.0, inertia = 1.0, extra = 2.0 }", "controllers[0].gamma.extra"),
])
def test_bad_options_name_the_key(tmp_path, options, key):
    text = configured(tmp_path, options).read_text()
    if options.startswith(("lam", "gamma")):  # replace the default instead of repeating the key
        name = options.split(" =")[0]
        text = text.replace(f"{name} = {'5.0' if name == 'lam' else '1.0'}\n", "", 1)
    path = tmp_path / "run.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        build(load_config(path))
    assert key in str(err.value)


def test_params0_scaled_per_link(tmp_path, puma):
    (c,) = build(load_config(configured(tmp_path, 'params0 = "scaled"\nparams_scale = [0.5, 1.4, 0.6, 1.3, 0.7, 1.5]'))).controllers
    np.testing.assert_allclose(c.params_hat, puma.params * np.array([0.5, 1.4, 0.6, 1.3, 0.7, 1.5])[:, None])


def test_params0_from_a_file(tmp_path, puma):
    p0 = puma.params * 0.8
    np.save(tmp_path / "p0.npy", p0)
    (c,) = build(load_config(configured(tmp_path, 'params0 = "p0.npy"'))).controllers
    np.testing.assert_array_equal(c.params_hat, p0)


@pytest.mark.slow
def test_rtctl_run_tracks_and_records_estimates(tmp_path):
    text = SHIPPED.read_text().replace('description = "robots/puma560.toml"',
                                       f'description = "{ROOT / "configs/robots/puma560.toml"}"')
    config = tmp_path / "cstar.toml"
    text = text.replace('path = "../runs/puma560_cstar_sim.msgpack"', 'path = "run.msgpack"')
    config.write_text(text.replace("realtime_factor = 1.0", "realtime_factor = 0.0"))
    summary = tmp_path / "summary.json"
    proc = subprocess.run([sys.executable, "-m", "rtctl.cli", "run", str(config), "--duration", "4",
                           "--summary", str(summary)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(summary.read_text())
    tracking = result["tracking_error_rad"]
    print(f"C* from zeros, 4 s: max {tracking['max_all']:.4f} rad, rms {tracking['rms_all']:.5f} rad")
    assert tracking["max_all"] < 0.03  # measured 0.0146 rad, in the first second while the estimates rise
    assert tracking["rms_all"] < 8e-3  # measured 3.9·10⁻³ rad over 4 s (2.5·10⁻³ over 10 s)
    tel = read(tmp_path / "run.msgpack")
    assert tel["params_hat"].shape[1] == 60 and tel["s"].shape[1] == 6
    assert np.all(np.isfinite(tel["params_hat"]))
