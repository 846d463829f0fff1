"""The paper's 16 sampling modes: "2^k × 2^k, 16 modes, k = 6..9" (§2), the horizontal and the
vertical density chosen independently. The geometry is written out here from the paper's
definition, not taken from the code: a grid of h samples a line and v lines a frame over the
full 512 × 512 screen. A single field holds every other line, so it has v/2 rows of h. The
paper's figures are a 256 × 512 field and a 256 × 256 field in 20 ms, and a 512 × 512 frame
in 40 ms. Each mode is checked in the settings, on the wire, and in the simulated camera's
picture."""
import itertools

import numpy as np
import pytest

from drivers.protocols.framegrabber import R_GEN, REG_NAMES, S_STATE, FAULT, decode, encode
from hil_sim.render import Scene
from rtctl.config import load_config
from rtctl.errors import ConfigError, ProtocolError, SettingsError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.runtime import build
from rtctl.vision.marker import locate
from vision_rig import CAMERA, READY, Rig

POWERS = [2 ** k for k in range(6, 10)]  # k = 6..9
MODES = list(itertools.product(POWERS, POWERS))  # (horizontal, vertical): 4 × 4 = 16
SCREEN = 512


def test_there_are_sixteen_modes_and_every_one_is_accepted():
    assert len(set(MODES)) == 16
    assert len({GrabberSettings(density=m) for m in MODES}) == 16  # 16 different settings, none refused


@pytest.mark.parametrize("h, v", MODES)
def test_geometry_of_each_mode(h, v):
    field = GrabberSettings(density=(h, v), levels=256, word_bits=8)  # the full grid, every field
    frame = GrabberSettings(density=(h, v), scan="frame", levels=256, word_bits=8)
    assert (field.rows, field.width, field.frame_bytes) == (v // 2, h, v // 2 * h)
    assert (frame.rows, frame.width, frame.frame_bytes) == (v, h, v * h)
    assert field.window == frame.window == (0, 0, h, v)
    # the window lies inside h columns and v rows, and nowhere else
    GrabberSettings(density=(h, v), window=(h - 32, v - 2, 32, 2))
    for window, what in (((h - 31, 0, 32, 2), f"x + width ≤ {h}"), ((0, v - 1, 32, 2), f"y + height ≤ {v}")):
        with pytest.raises(SettingsError, match="window") as e:
            GrabberSettings(density=(h, v), window=window)
        assert what in str(e.value)
    # the registers carry it: what the device decodes is what the host programmed
    assert decode(encode(field)) == field and decode(encode(frame)) == frame


def test_the_papers_fields_and_frame():
    assert (GrabberSettings(density=(256, 512)).rows, GrabberSettings(density=(256, 512)).width) == (256, 256)
    assert (GrabberSettings(density=512).rows, GrabberSettings(density=512).width) == (256, 512)
    assert (GrabberSettings(density=512, scan="frame").rows, GrabberSettings(density=512, scan="frame").width) == (
        512, 512)
    # a square pair is the square mode: one form per mode
    assert GrabberSettings(density=[256, 256]) == GrabberSettings(density=256)
    assert GrabberSettings(density=[256, 256]).density == 256


@pytest.mark.parametrize("density, key, message", [
    ((256, 1024), "density.vertical", "got [256, 1024]"),
    ((48, 512), "density.horizontal", "k = 6..9"),
    ((256,), "density", "[horizontal, vertical]"),
    ((64, 64, 64), "density", "got [64, 64, 64]"),
    ((256, 512.0), "density.vertical", "an integer"),
    ((True, 512), "density.horizontal", "an integer"),
    ("256x512", "density", "an integer"),
])
def test_a_bad_mode_is_refused_naming_the_key(density, key, message):
    with pytest.raises(SettingsError) as e:
        GrabberSettings(density=density)
    assert e.value.key == key and message in str(e.value)


CONFIG = """
[robot]
description = "{robot}"
[loop]
realtime_factor = 0.0
[sim]
[[devices]]
name = "camera"
kind = "framegrabber"
driver = "framegrabber"
{device}
[devices.settings]
{settings}
[devices.scene.camera]
position = [1.7, -1.2, 0.9]
look_at = [0.35, 0.05, 0.0]
"""


@pytest.mark.parametrize("settings, device, key_path, message", [
    ("density = [256, 1024]", "", "devices[0].settings.density.vertical", "k = 6..9"),
    ("density = [256]", "", "devices[0].settings.density", "[horizontal, vertical]"),
    ("density = [256, 512]\nwindow = [0, 0, 512, 512]", "", "devices[0].settings.window", "x + width ≤ 256"),
    ("", "transfer_mb_s = 0", "devices[0].transfer_mb_s", "a positive number"),
])
def test_a_bad_mode_in_a_config_names_file_and_key(tmp_path, settings, device, key_path, message):
    from runtime_helpers import PUMA

    path = tmp_path / "vision.toml"
    path.write_text(CONFIG.format(robot=PUMA, settings=settings, device=device))
    with pytest.raises(ConfigError) as e:
        build(load_config(path))
    assert e.value.key_path == key_path and message in e.value.expected and e.value.file == str(path)


def test_a_bad_mode_exits_2_before_anything_opens(tmp_path):
    from runtime_helpers import PUMA, rtctl

    path = tmp_path / "vision.toml"
    path.write_text(CONFIG.format(robot=PUMA, settings="density = [512, 32]", device=""))
    r = rtctl("check", path)
    assert r.returncode == 2, r.stderr
    assert "devices[0].settings.density.vertical" in r.stderr and "k = 6..9" in r.stderr and str(path) in r.stderr


# -- the wire: the vertical density register is checked like every word ------------------------
def test_a_bad_vertical_density_register_is_the_devices_fault_and_the_hosts_error():
    rig = Rig(GrabberSettings(density=(64, 128), scan="fields"))
    assert rig.frames(0.05)
    regs = rig.memory.regs
    regs[R_GEN] += 1
    regs[1 + REG_NAMES.index("density_v")] = 1000
    regs[R_GEN] += 1
    with pytest.raises(ProtocolError, match="the device reports FAULT"):
        rig.frames(0.1)
    assert rig.memory.status[S_STATE] == FAULT and rig.camera.settings.density == (64, 128)


def test_a_host_that_attaches_late_checks_the_frames_vertical_density_register():
    from drivers.protocols.framegrabber import F_REGS
    from drivers.protocols.framegrabber_host import HostPort

    rig = Rig(GrabberSettings(density=(128, 256), scan="fields"))
    rig.frames(0.05)
    late = HostPort(rig.memory)  # attaches after the programming: trusts only the frame's own registers
    rig.camera.step(round((rig.t + 0.02) * 1e9))
    slot = int(rig.memory.writer[0])
    rig.memory.slot_headers[slot][F_REGS + REG_NAMES.index("density_v")] = 96
    with pytest.raises(ProtocolError, match="registers are no settings.*density.vertical"):
        late.take(rig.t + 0.02, 0)


# -- the picture: every mode samples the same screen ----------------------------------------------
BIG_MARKER = Scene(CAMERA, marker_radius=0.05, noise=0.0)  # a few grid pixels even at density 64


@pytest.mark.parametrize("h, v", MODES)
def test_the_camera_draws_each_mode_on_its_grid(h, v):
    from rtctl.model import kinematics

    rig = Rig(GrabberSettings(density=(h, v), scan="frame", word_bits=8), scene=BIG_MARKER)
    _, frame = rig.frames(0.05)[0]
    pixels = frame.pixels()
    assert pixels.shape == (v, h)
    u, w = CAMERA.project(kinematics.fk(rig.model, READY)[:3, 3])  # screen pixels
    sh, sv = SCREEN / h, SCREEN / v  # screen pixels a grid step; grid pixel c is centred at s·c + (s − 1)/2
    col, row = (u - (sh - 1) / 2) / sh, (w - (sv - 1) / 2) / sv
    out = np.zeros(4)
    half = (int(40 / sv) + 3, int(40 / sh) + 3)  # ±40 screen px: the marker (~19 px) and some background
    assert locate(pixels, (row, col), half, 256, 0.2, out)
    # where the marker is on the screen, whatever the grid: within a screen pixel (measured: ≤ 0.94,
    # the coarse grids' centroid on a 19-pixel disc; a grid mistaken for square is tens of pixels off)
    assert abs(out[0] - row) * sv < 1.0 and abs(out[1] - col) * sh < 1.0


@pytest.mark.parametrize("h, v", MODES)
def test_a_saved_picture_of_each_mode_keeps_the_screens_square_aspect(h, v):
    from rtctl.hal.framegrabber import Frame
    from rtctl.vision.grab import _image
    from rtctl.vision.pixels import unpack

    for scan, field in (("fields", "odd"), ("frame", "frame")):
        s = GrabberSettings(density=(h, v), scan=scan, word_bits=8)
        picture = _image(Frame(1, 0.0, field, s, np.zeros((s.rows, s.words_per_row), np.uint8), unpack))
        assert picture.shape[0] == picture.shape[1] >= min(h, v // 2)  # the full screen is square
