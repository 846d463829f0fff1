"""The framegrabber's per-tick path allocates nothing that lasts, and no image-sized temporary:
the host's poll, the lock-step camera (posing, drawing, digitising, packing, publishing) and
the observer, with and without a new image."""
import numpy as np

from allocations import growth_and_peak
from rtctl.control.base import Reference
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.hal.joints import JointCommand, JointState
from rtctl.vision.observer import MarkerObserver
from vision_rig import CAMERA, READY, Rig


def _growth_and_peak(fn, calls):
    fn()  # compiled paths loaded
    return growth_and_peak(fn, calls)


def test_poll_with_nothing_new_allocates_nothing():
    rig = Rig(GrabberSettings())
    rig.frames(0.05)
    growth, peak = _growth_and_peak(lambda: rig.host.take(1.0, 0), 5000)
    assert growth <= 64 and peak <= 512, (growth, peak)


def test_camera_and_observer_ticks():
    rig = Rig(GrabberSettings(), q=lambda t: READY + 0.1 * np.sin(t))
    observer = MarkerObserver("marker", rig.model, CAMERA)
    grabber = type("G", (), {"frame": None, "grab": lambda self: self.frame})()
    observer.grabber = grabber
    state, ref, command = JointState(6), Reference(6), JointCommand(6)
    state.position[:] = READY
    observer.reset(state)
    seen = np.zeros(1, dtype=np.int64)  # images observed (a list would grow inside the measurement)

    def tick():
        rig.t = t = rig.tick * rig.period
        rig.camera.step(round(t * 1e9))
        grabber.frame = rig.host.take(t, 0)
        if grabber.frame is not None:
            seen[0] += 1
        observer.update(t, state, ref, command)
        rig.tick += 1

    # every kernel loaded, and past 2**32 ns: the nanosecond stamps kept between ticks are then
    # ints of their final size (they hold 288 B more from 4.3 s on, whatever the window's length)
    rig.frames(4.5)
    short, _ = _growth_and_peak(tick, 1000)
    growth, peak = _growth_and_peak(tick, 3000)  # 3 s: 150 fields, each posed, drawn in bands, published, observed
    assert seen[0] >= 190 and observer.found == observer.images
    # nothing retained beyond the image in flight (its small bookkeeping), whatever the length;
    # the largest temporary is the kinematics' few small arrays, far below a band of the
    # picture (a 512-pixel row of float32 is 2 KiB, a band 13 rows)
    assert growth <= 2048 and growth - short <= 256 and peak <= 16 * 1024, (short, growth, peak)


def test_observer_tick_without_an_image_allocates_nothing():
    rig = Rig(GrabberSettings())
    observer = MarkerObserver("marker", rig.model, CAMERA)
    observer.grabber = type("G", (), {"grab": lambda self: None})()
    state, ref, command = JointState(6), Reference(6), JointCommand(6)
    observer.reset(state)
    growth, peak = _growth_and_peak(lambda: observer.update(0.5, state, ref, command), 5000)
    assert growth <= 64 and peak <= 512, (growth, peak)


def test_the_first_reset_loads_the_per_image_kernels_even_after_an_update(monkeypatch):
    """The daemon's warm-up calls update() (no image) before the loop's reset(): that reset must
    still load the kernels, or the first image compiles them inside the loop (a cold cache
    stalled a HIL run 0.6 s there and the drives' watchdog stopped them)."""
    rig = Rig(GrabberSettings())
    observer = MarkerObserver("marker", rig.model, CAMERA)
    observer.grabber = type("G", (), {"grab": lambda self: None})()
    state, ref, command = JointState(6), Reference(6), JointCommand(6)
    warmed = []
    monkeypatch.setattr(observer, "_warm_up", lambda s: warmed.append(s))
    observer.update(0.0, state, ref, command)
    observer.reset(state)
    assert warmed == [state]
    observer.reset(state)  # a later reset: they are loaded already
    assert warmed == [state]
