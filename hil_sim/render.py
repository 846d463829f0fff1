"""The simulated camera's picture: the robot seen by a fixed pinhole camera (docs/framegrabber.md).

The scene is a dark background (brighter towards the bottom), a pedestal under the base, the
links as thick segments (capsules) between successive joint frames, and a bright spherical
marker at the tool point,
drawn last (never occluded). Edges are anti-aliased by coverage (a one-pixel ramp), so the
marker's intensity centroid is its projected centre to a small fraction of a pixel. Sensor
noise is added per pixel (a sum of four uniforms, scaled to ``noise``).

Rendering works on the density grid of the grabber's settings and on any subset of the rows
of one image (a band), so the lock-step simulator can spread a field over the ticks it takes.
Geometry is in units of the grid's columns; when the vertical density differs from the
horizontal one (the paper's non-square modes), a grid row sits at its screen height in those
units, so a circle on the screen stays a circle in the picture.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from rtctl.model import kinematics
from rtctl.vision.camera import Camera

NOISE_SAMPLES = 1 << 16  # a table of Gaussian samples, read from a new place every field


@dataclass(frozen=True)
class Scene:
    camera: Camera
    marker_radius: float = 0.015  # m
    link_radius: float = 0.035  # m
    pedestal: float = 0.5  # m of column below the base (drawn twice as thick as the links); 0: none
    background: float = 0.12  # video level at the top of the picture …
    background_slope: float = 0.10  # … plus this at the bottom
    link_level: float = 0.45
    marker_level: float = 0.95
    noise: float = 0.004  # standard deviation of the sensor noise (video level)
    seed: int = 1

    @classmethod
    def from_table(cls, t) -> "Scene":
        camera = Camera.from_table(t.table("camera"))
        scene = cls(camera, marker_radius=t.float("marker_radius", 0.015, positive=True),
                    link_radius=t.float("link_radius", 0.035, positive=True),
                    pedestal=t.float("pedestal", 0.5, min=0.0),
                    background=t.float("background", 0.12, min=0.0, max=1.0),
                    background_slope=t.float("background_slope", 0.10, min=-1.0, max=1.0),
                    link_level=t.float("link_level", 0.45, min=0.0, max=1.0),
                    marker_level=t.float("marker_level", 0.95, min=0.0, max=1.0),
                    noise=t.float("noise", 0.004, min=0.0, max=0.5), seed=t.int("seed", 1))
        t.done()
        return scene


@njit(cache=True)
def _render_rows(img, i_begin, i_end, i_step, row0, row_step, col0, density_v, rho, bg0, bg1, noise, noise_at,
                 seg, radius, value):
    """Rows i_begin, i_begin + i_step, … < i_end of ``img``: image row i is grid row
    g = row0 + i·row_step, at height rho·g + (rho − 1)/2 in column units (rho = horizontal /
    vertical density: the same screen height), column j grid column col0 + j. Capsules k from
    (seg[k,0], seg[k,1]) to (seg[k,2], seg[k,3]) in column units, radius[k], video level
    value[k], drawn in order; then ``noise[(noise_at + pixel index) mod len]`` added."""
    cols = img.shape[1]
    mask = noise.shape[0] - 1  # (a power of two)
    for i in range(i_begin, i_end, i_step):
        g = row0 + i * row_step
        y = rho * g + (rho - 1.0) / 2.0
        level = bg0 + bg1 * g / density_v
        for j in range(cols):
            img[i, j] = level
        for k in range(seg.shape[0]):
            r = radius[k]
            if not r > 0.0:
                continue
            x0, y0, x1, y1 = seg[k, 0], seg[k, 1], seg[k, 2], seg[k, 3]
            reach = r + 1.0
            if y < min(y0, y1) - reach or y > max(y0, y1) + reach:
                continue
            dx, dy = x1 - x0, y1 - y0
            length2 = dx * dx + dy * dy
            lo, hi = min(x0, x1) - reach, max(x0, x1) + reach
            if length2 > 0.0 and dy * dy > 1e-6 * length2:  # where this row crosses the band around the line
                length = np.sqrt(length2)
                ux, uy = dx / length, dy / length
                xc = x0 + (y - y0) * ux / uy
                half = reach / abs(uy)
                lo, hi = max(lo, xc - half), min(hi, xc + half)
            j_lo = max(int(np.floor(lo)) - col0, 0)
            j_hi = min(int(np.ceil(hi)) - col0 + 1, cols)
            v = value[k]
            for j in range(j_lo, j_hi):
                x = col0 + j
                s = 0.0
                if length2 > 0.0:
                    s = ((x - x0) * dx + (y - y0) * dy) / length2
                    s = min(max(s, 0.0), 1.0)
                ex, ey = x - x0 - s * dx, y - y0 - s * dy
                c = r + 0.5 - np.sqrt(ex * ex + ey * ey)  # coverage of a one-pixel ramp
                if c > 0.0:
                    if c > 1.0:
                        c = 1.0
                    img[i, j] += c * (v - img[i, j])
        base = noise_at + i * cols
        for j in range(cols):
            img[i, j] += noise[(base + j) & mask]


class Renderer:
    """Geometry of the robot in one pose, frozen for a field, drawn band by band."""

    def __init__(self, scene: Scene, model):
        self.scene, self.model = scene, model
        n = model.nq
        self.tool_in_last = (model.flange @ model.tool)[:, 3]  # the tool point in the last body
        # points: the base, the body origins, the tool point, the pedestal's foot; segments
        # between them: each body from its parent's origin (or the base), the tool, the pedestal
        self.points = np.zeros((n + 3, 3))
        self.points[-1, 2] = -scene.pedestal
        self.a = np.array([p + 1 if p >= 0 else 0 for p in model.parent] + [n, 0])
        self.b = np.array(list(range(1, n + 1)) + [n + 1, n + 2])
        self.thickness = np.full(n + 2, scene.link_radius)
        self.thickness[-1] = 2 * scene.link_radius if scene.pedestal > 0 else np.nan
        self.seg = np.zeros((n + 3, 4))  # the segments far to near, then the marker
        self.radius = np.zeros(n + 3)
        self.value = np.full(n + 3, scene.link_level)
        self.value[-1] = scene.marker_level
        self.marker_screen = np.zeros(2)  # where the true marker projects (screen pixels)
        rng = np.random.default_rng(scene.seed)
        self.noise = (rng.standard_normal(NOISE_SAMPLES) * scene.noise).astype(np.float32)
        self.noise_at = 0

    def freeze(self, q, density_h: int, field: int = 0) -> None:
        """Project the robot at ``q`` onto the grid of horizontal density ``density_h``, in
        units of its columns (segments far to near, marker last)."""
        n, scene, cam, pts = self.model.nq, self.scene, self.scene.camera, self.points
        poses = kinematics.link_poses(self.model, q)
        pts[1:n + 1] = poses[:, :3, 3]
        pts[n + 1] = (poses[-1] @ self.tool_in_last)[:3]
        in_camera = pts @ cam.R.T + cam.t
        z = in_camera[:, 2]
        scale = density_h / 512
        px = cam.focal_px * scale  # focal length in grid pixels
        with np.errstate(divide="ignore", invalid="ignore"):  # (a point behind the camera: NaN, not drawn)
            grid = (cam.focal_px * in_camera[:, :2] / np.where(z > 0, z, np.nan)[:, None] + cam.principal
                    - (1 / scale - 1) / 2) * scale
            depth = 0.5 * (z[self.a] + z[self.b])
            order = np.argsort(-depth)  # painter's algorithm: far first
            a, b = self.a[order], self.b[order]
            self.seg[:-1, :2], self.seg[:-1, 2:] = grid[a], grid[b]
            self.radius[:-1] = px * self.thickness[order] / depth[order]
            self.radius[:-1][~np.isfinite(self.seg[:-1]).all(axis=1)] = np.nan
            self.marker_screen[:] = grid[n + 1] / scale + (1 / scale - 1) / 2
            self.seg[-1, :2] = self.seg[-1, 2:] = grid[n + 1]
            self.radius[-1] = px * scene.marker_radius / z[n + 1]  # NaN or ≤ 0 behind: not drawn
        self.noise_at = (field * 7919 * 64) % NOISE_SAMPLES

    def draw(self, img, rows: range, row0: int, row_step: int, col0: int, density_h: int, density_v: int) -> None:
        """Render the image rows ``rows`` (a range) of ``img`` (float32, (rows, width)) on the
        grid ``density_h`` × ``density_v`` (the horizontal one the one :meth:`freeze` used)."""
        s = self.scene
        _render_rows(img, rows.start, rows.stop, rows.step, row0, row_step, col0, density_v, density_h / density_v,
                     s.background,
                     s.background_slope, self.noise, self.noise_at, self.seg, self.radius, self.value)
