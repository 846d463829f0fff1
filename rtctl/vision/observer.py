"""The tool marker watched in the loop: measured where the camera sees it, predicted by
forward kinematics (docs/framegrabber.md, "The marker in the loop").

An observer: it owns no joint command (``joints = []``) and uses one framegrabber
(``devices = ["camera"]``). When the grabber has a new image, the observer takes the robot's
joint positions at the image's capture time (interpolated in a short history of what it saw),
projects the model's tool point through its camera calibration (the *prediction*), and looks
for the marker in a box around that point (the *measurement*). Telemetry, in screen pixels
(the 512 × 512 grid), per image: ``marker_measured_px``, ``marker_predicted_px``,
``marker_error_px`` (measured − predicted), ``marker_capture_t`` and ``marker_seq``; NaN when
the marker was not found. A wrong tool frame or camera calibration shows as a consistent error.

Work per tick: one history row. Per new image: the kinematics (a few small arrays, the only
allocation), unpacking only the rows of the search box and a centroid over the box —
``rtctl bench grabber`` measures it against its budget of 0.3 ms.

Options: ``[controllers.camera]`` (the calibration: :class:`rtctl.vision.camera.Camera`),
``search_px`` (half the search box, screen pixels; default 32), ``min_contrast`` (fraction of
full scale; default 0.2), ``history`` (rows of joint positions kept; default 256).
"""
from __future__ import annotations

import numpy as np

from rtctl.control.base import Controller
from rtctl.hal.framegrabber import Frame, FrameGrabber, GrabberSettings
from rtctl.model import kinematics
from rtctl.vision.camera import SCREEN, Camera
from rtctl.vision import marker
from rtctl.vision.marker import locate
from rtctl.vision.pixels import unpack


SEARCH_PX = 32.0  # the search box's half-size by default, in screen pixels
MIN_CONTRAST = 0.2  # the least brightest-minus-mean of a marker by default, a fraction of full scale
HISTORY = 256  # ticks of joint positions remembered by default


class MarkerObserver(Controller):
    def __init__(self, name, model, camera: Camera, *, divisor: int = 1, search_px: float = SEARCH_PX,
                 min_contrast: float = MIN_CONTRAST, history: int = HISTORY):
        super().__init__(name, model, joints=(), divisor=divisor)
        self.camera, self.search_px, self.min_contrast = camera, float(search_px), float(min_contrast)
        self.grabber: FrameGrabber | None = None
        self._t = np.full(history, -np.inf)  # ring of (t, q): the joint positions seen
        self._q = np.zeros((history, model.nq))
        self._k = 0
        self._warm = False  # the per-image kernels loaded (by the first reset)
        self._q_at = np.zeros(model.nq)
        self._tool_in_last = (model.flange @ model.tool)[:, 3]
        self._rows = np.zeros((0, 0), dtype=np.uint8)  # the search box's rows, unpacked
        self._found = np.zeros(4)
        self._grid = np.zeros(2)
        self.images = self.found = 0
        self.internals = {"marker_measured_px": np.full(2, np.nan), "marker_predicted_px": np.full(2, np.nan),
                          "marker_error_px": np.full(2, np.nan), "marker_capture_t": np.full((), np.nan),
                          "marker_seq": np.zeros((), dtype=np.int64)}

    @classmethod
    def from_config(cls, c, model) -> "MarkerObserver":
        o = c.options
        if c.joints:
            raise o.error("joints", "[] — an observer owns no joint command")
        camera = Camera.from_table(o.table("camera"))
        obs = cls(c.name, model, camera, divisor=c.divisor, search_px=o.float("search_px", SEARCH_PX, positive=True),
                  min_contrast=o.float("min_contrast", MIN_CONTRAST, positive=True, max=1.0),
                  history=o.int("history", HISTORY, min=4, max=100_000))
        o.done()
        return obs

    def bind(self, devices: dict) -> None:
        grabbers = [d for d in devices.values() if isinstance(d, FrameGrabber)]
        if len(devices) != 1 or len(grabbers) != 1:
            raise ValueError(f"{type(self).__name__} uses exactly one framegrabber device; got "
                             f"{', '.join(f'{n} ({type(d).__name__})' for n, d in devices.items()) or 'none'}")
        self.grabber = grabbers[0]

    def reset(self, state) -> None:
        """Forget the history; the first time, load the per-image kernels (before "started" —
        also when the daemon's warm-up has already called update(), which no image reaches)."""
        if not self._warm:
            self._warm_up(state)
            self._warm = True
        self._t.fill(-np.inf)
        self._k = 0

    def _warm_up(self, state) -> None:
        marker.warm_up()
        settings = GrabberSettings(density=64, scan="frame", word_bits=8)
        words = np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8)
        words[30:34, 30:34] = 255
        self._t[0], self._q[0], self._k = 0.0, state.position, 1
        saved = {k: v.copy() for k, v in self.internals.items()}
        self.observe(Frame(0, 0.0, "frame", settings, words, unpack))
        for k, v in saved.items():
            self.internals[k][...] = v
        self.images = self.found = 0

    def update(self, t, state, ref, command) -> None:
        k = self._k % self._t.size
        self._t[k] = t
        self._q[k] = state.position
        self._k += 1
        frame = self.grabber.grab()
        if frame is not None:
            self.observe(frame)

    # -- one image ---------------------------------------------------------------------------
    def observe(self, frame) -> bool:
        """Predict and measure the marker in ``frame``; update the telemetry. True if found."""
        i = self.internals
        self.images += 1
        i["marker_seq"][()] = frame.seq
        i["marker_capture_t"][()] = frame.capture_time
        predicted, measured = i["marker_predicted_px"], i["marker_measured_px"]
        self._positions_at(frame.capture_time)
        poses = kinematics.link_poses(self.model, self._q_at)
        tool = poses[-1] @ self._tool_in_last
        self.camera.project_point(tool, predicted)
        found = self.measure(frame, predicted, measured)
        self.found += found
        np.subtract(measured, predicted, out=i["marker_error_px"])
        return found

    def measure(self, frame, guess, out) -> bool:
        """The marker near ``guess`` (screen px) in ``frame`` → ``out`` (screen px), NaN if not found."""
        s = frame.settings
        x, y = s.window[0], s.window[1]
        step = 1 if frame.field == "frame" else 2
        parity = frame.field == "even"
        self._grid[:] = Camera.to_grid(guess, s.density) if np.isfinite(guess).all() else np.nan
        col, grid_row = self._grid[0] - x, self._grid[1]
        row = (grid_row - y - parity) / step  # image row of the guess
        half_cols = max(2, int(np.ceil(self.search_px * s.density_h / SCREEN)))
        half_rows = max(2, int(np.ceil(self.search_px * s.density_v / SCREEN / step)))
        out[:] = np.nan
        if not np.isfinite(row):
            return False
        r0, r1 = max(int(row) - half_rows, 0), min(int(row) + half_rows + 1, s.rows)
        if r0 >= r1:
            return False
        if self._rows.shape[1] != s.width or self._rows.shape[0] < s.rows:
            self._rows = np.zeros((s.rows, s.width), dtype=np.uint8)
        box = self._rows[:r1 - r0]
        frame.pixels(box, slice(r0, r1))
        if not locate(box, (row - r0, col), (half_rows, half_cols), s.levels, self.min_contrast, self._found):
            return False
        self._grid[0] = x + self._found[1]
        self._grid[1] = y + parity + step * (r0 + self._found[0])
        out[:] = Camera.to_screen(self._grid, s.density)
        return True

    def _positions_at(self, t: float) -> None:
        """Joint positions at time ``t``, linear between the two history rows around it."""
        ts, n = self._t, self._t.size
        newest = (self._k - 1) % n
        if t >= ts[newest]:
            self._q_at[:] = self._q[newest]
            return
        for back in range(1, min(self._k, n)):
            older = (newest - back) % n
            if ts[older] <= t:
                newer = (older + 1) % n
                w = (t - ts[older]) / (ts[newer] - ts[older])
                np.subtract(self._q[newer], self._q[older], out=self._q_at)
                self._q_at *= w
                self._q_at += self._q[older]
                return
        self._q_at[:] = self._q[(self._k - min(self._k, n)) % n]  # older than the history: the oldest
