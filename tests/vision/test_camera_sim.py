"""The simulated camera and grabber in lock-step: PAL timing on the loop's clock, the fields'
lines, the registers (settings, N-shot, a bad program), and what the picture shows."""
import numpy as np
import pytest

from drivers.protocols.framegrabber import FAULT, R_GEN, S_STATE, W_WRITTEN
from hil_sim.render import Scene
from rtctl.errors import ProtocolError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.vision.camera import Camera
from rtctl.vision.marker import locate
from vision_rig import CAMERA, Rig

QUIET = Scene(CAMERA, noise=0.0)


@pytest.mark.parametrize("scan, period, first_capture, fields", [
    ("fields", 0.020, 0.000, ["odd", "even"]),
    ("odd", 0.040, 0.000, ["odd"]),
    ("even", 0.040, 0.020, ["even"]),
    ("frame", 0.040, 0.000, ["frame"]),
])
def test_pal_timing_on_the_loop_clock(scan, period, first_capture, fields):
    rig = Rig(GrabberSettings(density=128, scan=scan))
    got = rig.frames(0.5)
    arrivals = np.array([a for a, _ in got])
    captures = np.array([f.capture_time for _, f in got])
    latency = 0.040 if scan == "frame" else 0.020  # an image is complete when its last field ends
    assert captures[0] == pytest.approx(first_capture)
    np.testing.assert_allclose(np.diff(captures), period, atol=1e-9)
    np.testing.assert_allclose(arrivals - captures, latency, atol=1e-9)
    assert [f.field for _, f in got][:4] == (fields * 4)[:4]
    assert [f.seq for _, f in got] == list(range(1, len(got) + 1))
    assert rig.host.dropped == 0


def test_the_work_of_a_field_is_spread_over_its_ticks():
    rig = Rig(GrabberSettings(scan="fields"), ticks_per_field=20)
    drawn = []
    original = rig.camera._draw_band
    rig.camera._draw_band = lambda b: (drawn.append((rig.tick, b)), original(b))
    rig.frames(0.1)
    per_tick = {}
    for tick, band in drawn:
        per_tick.setdefault(tick, []).append(band)
    assert max(len(b) for b in per_tick.values()) == 1  # one band per tick
    assert all(tick % 20 != 0 for tick in per_tick)  # the tick that poses the robot draws nothing


def test_interlaced_frame_is_the_two_fields():
    at_rest = {scan: Rig(GrabberSettings(scan=scan, window=(64, 32, 384, 400)), scene=QUIET).frames(0.1)
               for scan in ("frame", "fields")}
    frame = at_rest["frame"][0][1].pixels()
    odd = next(f for _, f in at_rest["fields"] if f.field == "odd").pixels()
    even = next(f for _, f in at_rest["fields"] if f.field == "even").pixels()
    assert frame.shape == (400, 384) and odd.shape == even.shape == (200, 384)
    np.testing.assert_array_equal(frame[0::2], odd)  # window y = 32: frame row 0 is grid row 32, an odd-field line
    np.testing.assert_array_equal(frame[1::2], even)
    assert not np.array_equal(odd, even)


def test_levels_are_the_top_bits_of_256_levels():
    images = {levels: Rig(GrabberSettings(levels=levels, word_bits=16, density=256)).frames(0.03)[0][1].pixels()
              for levels in (256, 16, 4, 2)}
    for levels, bits in ((16, 4), (4, 2), (2, 1)):
        np.testing.assert_array_equal(images[levels], images[256] >> (8 - bits))
    assert set(np.unique(images[2])) == {0, 1}


def test_marker_is_drawn_where_the_camera_projects_the_tool():
    from rtctl.model import kinematics

    rig = Rig(GrabberSettings(scan="frame"))
    _, frame = rig.frames(0.05)[0]
    tool = kinematics.fk(rig.model, rig.q(0.0))[:3, 3]
    u, v = CAMERA.project(tool)
    out = np.zeros(4)
    assert locate(frame.pixels(), (v, u), (16, 16), 256, 0.2, out)
    # within a tenth of a pixel (sensor noise; the link under the marker's edge)
    assert out[0] == pytest.approx(v, abs=0.1) and out[1] == pytest.approx(u, abs=0.1)


def test_settings_change_at_the_next_image_and_frames_carry_theirs():
    rig = Rig(GrabberSettings(density=128, scan="fields"))
    before = rig.frames(0.05)
    new = GrabberSettings(density=256, window=(32, 64, 64, 32), scan="odd", levels=4, word_bits=8)
    rig.host.program(new)
    after = rig.frames(0.2)
    assert all(f.settings.density == 128 for _, f in before)
    assert after[-1][1].settings == new and after[-1][1].pixels().shape == (16, 64)
    switched = [f.settings == new for _, f in after]
    assert switched == sorted(switched)  # once switched, it stays


def test_n_shot_takes_n_images_then_waits_for_a_trigger():
    rig = Rig(GrabberSettings(density=64, scan="fields", shots=3))
    assert len(rig.frames(0.3)) == 3
    rig.host.program(GrabberSettings(density=64, scan="fields", shots=3))  # the trigger register moves
    assert len(rig.frames(0.3)) == 3


def test_a_bad_program_is_refused_the_old_settings_stay_and_the_host_reports_the_fault():
    rig = Rig(GrabberSettings(density=64, scan="fields"))
    rig.frames(0.05)
    regs = rig.memory.regs
    regs[R_GEN] += 1
    regs[1] = 1000  # density 1000
    regs[R_GEN] += 1
    written = int(rig.memory.writer[W_WRITTEN])
    with pytest.raises(ProtocolError, match="the device reports FAULT"):  # the host's poll names it
        rig.frames(0.1)
    assert rig.memory.status[S_STATE] == FAULT and rig.camera.settings_errors == 1
    for k in range(1, 101):  # the device goes on with the settings it had
        rig.camera.step(round((rig.t + k * rig.period) * 1e9))
    assert rig.memory.writer[W_WRITTEN] > written and rig.camera.settings.density == 64


def test_pinhole_projection_by_hand():
    # camera 2 m along +x looking at the origin (towards −x), z up: image right is +y, image down −z
    cam = Camera.looking_at((2.0, 0.0, 0.0), (0.0, 0.0, 0.0), 500.0, principal=(255.5, 255.5))
    np.testing.assert_allclose(cam.project(np.array([0.0, 0.0, 0.0])), [255.5, 255.5])
    np.testing.assert_allclose(cam.project(np.array([0.0, -0.2, 0.1])), [255.5 - 50, 255.5 - 25])
    np.testing.assert_allclose(cam.project(np.array([1.0, 0.0, 0.1])), [255.5, 255.5 - 50])
    assert np.isnan(cam.project(np.array([3.0, 0.0, 0.0]))).all()  # behind the camera
    np.testing.assert_allclose(Camera.to_screen(Camera.to_grid([100.0, 7.25], 128), 128), [100.0, 7.25])
    np.testing.assert_allclose(Camera.to_grid([1.5, 3.5], 128), [0.0, 0.5])  # grid pixel 0 spans screen 0..3


@pytest.mark.parametrize("scale", [1.0, 1e300])
def test_a_camera_far_away_or_with_a_huge_up_vector_is_still_a_rotation_looking_at_its_target(scale):
    """Only directions matter for the orientation. A camera ``scale`` m out along −x looking at the
    origin with up = scale·z, by hand: line of sight z = +x, image right = z × up = (1, 0, 0) ×
    (0, 0, 1) = (0, −1, 0), image down = z × right = (0, 0, −1): those are R's rows, whatever the
    scale. The target projects to the principal point; nothing overflows on the way (numpy's
    floating-point warnings are errors here)."""
    with np.errstate(all="raise"):
        cam = Camera.looking_at((-scale, 0.0, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, scale))
        assert np.array_equal(cam.R, [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
        assert np.allclose(cam.project(np.zeros(3)), cam.principal)


def test_a_zero_or_unbounded_direction_is_refused_with_what_is_wrong():
    with pytest.raises(ValueError, match="up direction must be a finite, non-zero vector"):
        Camera.looking_at((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="finite point other than its own position"):
        Camera.looking_at((-1e308, 0.0, 0.0), (1e308, 0.0, 0.0))  # (the line of sight overflows)
