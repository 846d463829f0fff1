"""The shipped vision configuration end to end: the daemon with the simulated camera and the
marker observer, its telemetry and plot; `rtctl grab`; wrong wiring of the observer refused."""
import json
import numpy as np
import pytest

from rtctl.config import load_config
from rtctl.errors import ConfigError
from rtctl.runtime import build
from rtctl.telemetry import read
from runtime_helpers import ROOT, rtctl

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

VISION = ROOT / "configs" / "puma560_vision_sim.toml"


@pytest.mark.slow
def test_run_records_the_marker_within_half_a_pixel(tmp_path):
    tel, summary = tmp_path / "run.msgpack", tmp_path / "summary.json"
    r = rtctl("run", VISION, "--realtime-factor", "0", "--duration", "1.5", "--telemetry", tel, "--summary", summary,
              "--socket", tmp_path / "s.sock", timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    s = json.loads(summary.read_text())
    camera = s["devices"]["camera"]
    assert camera["frames"] >= 70 and camera["dropped"] == 0 and camera["device"]["no_free_slot"] == 0
    t = read(tel)
    seq = t["marker_seq"]
    first = np.unique(seq, return_index=True)[1][1:]  # the tick each image was observed (seq 0: none yet)
    error = t["marker_error_px"][first]
    assert len(first) == camera["frames"] and not np.isnan(error).any()
    assert np.sqrt(np.mean(np.sum(error ** 2, axis=1))) <= 0.5
    # the capture time on the loop's clock: a field is observed 20 ms after it was sampled
    np.testing.assert_allclose(t["t"][first] - t["marker_capture_t"][first], 0.020, atol=1e-6)
    png = tmp_path / "plot.png"
    r = rtctl("plot", tel, "-o", png)
    assert r.returncode == 0 and png.stat().st_size > 10_000, r.stderr
    from rtctl.plot import figure

    axes = {ax.get_title(): ax for ax in figure(tel).axes}
    lines = {ln.get_label(): ln for ln in axes["tool marker in the image"].get_lines()}
    errors = {ln.get_label(): ln for ln in axes["marker measured − predicted"].get_lines()}
    for k, axis in enumerate("uv"):  # each line is the column it claims, against the recorded time
        np.testing.assert_array_equal(lines[f"{axis} measured"].get_xdata(), t["t"])
        np.testing.assert_array_equal(lines[f"{axis} measured"].get_ydata(), t["marker_measured_px"][:, k])
        np.testing.assert_array_equal(lines[f"{axis} predicted"].get_ydata(), t["marker_predicted_px"][:, k])
        np.testing.assert_array_equal(errors[axis].get_ydata(), t["marker_error_px"][:, k])


def test_grab_saves_the_frame_with_the_marker(tmp_path):
    from PIL import Image

    from rtctl.model import kinematics
    from rtctl.vision.camera import Camera

    out = tmp_path / "img" / "frame.png"
    r = rtctl("grab", VISION, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "odd 256×512" in r.stdout
    image = np.asarray(Image.open(out))
    assert image.shape == (512, 512)  # the odd field, line-doubled
    cfg = load_config(VISION)
    cam = Camera.from_table(cfg.controllers[1].options.table("camera"))
    u, v = cam.project(kinematics.fk(cfg.model, np.array(cfg.sim.vector("initial_q", 6)))[:3, 3])
    rows, cols = np.nonzero(image > 200)  # the marker is the only thing that bright
    assert abs(cols.mean() - u) < 1.0 and abs(rows.mean() - v) < 1.5


def test_grab_without_a_framegrabber_exits_2(tmp_path):
    r = rtctl("grab", ROOT / "configs" / "puma560_sim.toml", "-o", tmp_path / "f.png")
    assert r.returncode == 2 and "framegrabber devices: none" in r.stderr


@pytest.mark.parametrize("edit, key, message", [
    (lambda s: s.replace('devices = ["camera"]', "devices = []"), "controllers[1].devices", "exactly one framegrabber"),
    (lambda s: s.replace('joints = []                  # an observer', '# (joints omitted: all of them)'),
     "controllers[1].joints", "one controller per joint"),
    (lambda s: s.replace('devices = ["camera"]', 'devices = ["camera", "cam2"]'), "controllers[1].devices",
     "unknown: 'cam2'"),
    (lambda s: s.replace("[controllers.camera]", "[controllers.lens]"), "controllers[1].camera", "missing"),
])
def test_observer_wiring_errors_name_the_key(tmp_path, edit, key, message):
    text = edit(VISION.read_text()).replace('"robots/puma560.toml"', f'"{ROOT / "configs/robots/puma560.toml"}"')
    path = tmp_path / "v.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as e:
        build(load_config(path))
    assert e.value.key_path == key and message in e.value.expected


def test_the_driver_without_its_device_is_a_hardware_error():
    from drivers.framegrabber import ShmFrameGrabber
    from rtctl.errors import HardwareError
    from rtctl.hal.framegrabber import GrabberSettings

    grabber = ShmFrameGrabber("camera", GrabberSettings(), "rtctl-fg-absent")
    with pytest.raises(HardwareError, match="no framegrabber shared memory 'rtctl-fg-absent'.*hil-sim"):
        grabber.configure()
    grabber.close()
