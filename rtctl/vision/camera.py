"""A fixed pinhole camera looking at the robot (docs/framegrabber.md, "Camera").

Image coordinates are *screen pixels*: the framegrabber's finest grid, 512 × 512 over the
full picture, pixel centres at integers, u to the right, v down. A grid of density d samples
every s = 512/d screen pixels; its pixel (col, row) has its centre at screen
(s·col + (s − 1)/2, s·row + (s − 1)/2) — :meth:`Camera.to_grid` and :meth:`Camera.to_screen`.
A grid with a horizontal density apart from its vertical one (h, v) has s = 512/h along u and
512/v along v.

The camera frame has z along the optical axis, x along u and y along v; ``R`` and ``t`` map
base coordinates into it (p_cam = R p + t), built from a position, a point looked at and the
base's up direction.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SCREEN = 512  # pixels across the full picture at the finest density
FOCAL_PX = 700.0  # the default focal length, in screen pixels
CENTRE = ((SCREEN - 1) / 2, (SCREEN - 1) / 2)  # the default principal point: the screen's centre
UP = (0.0, 0.0, 1.0)  # the default up direction: the base's +z


def _unit(v: np.ndarray) -> np.ndarray | None:
    """v / |v|, scaled first so that no square overflows (a camera 1e300 m away still has a
    line of sight); None for a zero or non-finite v."""
    scale = np.abs(v).max()
    if not (scale > 0 and np.isfinite(scale)):
        return None
    v = v / scale
    return v / np.linalg.norm(v)


def look_at(position, target, up) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of a camera at ``position`` looking at ``target`` with ``up`` up in the image."""
    position, target, up = (np.asarray(x, dtype=float) for x in (position, target, up))
    with np.errstate(over="ignore"):  # (an infinite difference is refused just below)
        z = _unit(target - position)
    if z is None:
        raise ValueError("the camera must look at a finite point other than its own position")
    up = _unit(up)
    if up is None:
        raise ValueError("the up direction must be a finite, non-zero vector")
    x = np.cross(z, up)  # image right; v (down) = z × x
    if not np.linalg.norm(x) > 1e-9:
        raise ValueError("the up direction must not be along the line of sight")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ position


@dataclass(frozen=True, eq=False)
class Camera:
    focal_px: float  # focal length in screen pixels
    principal: np.ndarray  # (u0, v0) in screen pixels
    R: np.ndarray = field(repr=False)  # base → camera rotation
    t: np.ndarray = field(repr=False)  # base → camera translation (m)

    @classmethod
    def looking_at(cls, position, target, focal_px: float = FOCAL_PX, principal=CENTRE, up=UP):
        if not focal_px > 0:
            raise ValueError(f"focal length must be positive, got {focal_px}")
        R, t = look_at(position, target, up)
        return cls(float(focal_px), np.array(principal, dtype=float).reshape(2), R, t)

    @classmethod
    def from_table(cls, t) -> "Camera":
        """``position``, ``look_at`` (m, base frame), ``up`` (default +z), ``focal_px`` (default 700),
        ``principal`` (default the screen's centre)."""
        position, target = t.vector("position", 3), t.vector("look_at", 3)
        up = t.vector("up", 3, np.array(UP))
        focal = t.float("focal_px", FOCAL_PX, positive=True)
        principal = t.vector("principal", 2, np.array(CENTRE))
        try:
            camera = cls.looking_at(position, target, focal, principal, up)
        except ValueError as e:
            raise t.error("look_at", str(e)) from None
        t.done()
        return camera

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """Base-frame points (..., 3) → camera-frame points (..., 3)."""
        return points @ self.R.T + self.t

    def project(self, points: np.ndarray) -> np.ndarray:
        """Base-frame points (..., 3) → screen pixels (..., 2); NaN behind the camera."""
        pc = self.to_camera(np.asarray(points, dtype=float))
        z = pc[..., 2:]
        z = np.where(z > 0, z, np.nan)  # (dividing by NaN warns of nothing)
        return self.focal_px * pc[..., :2] / z + self.principal

    def project_point(self, p, out: np.ndarray) -> bool:
        """One base-frame point → ``out`` = (u, v) screen pixels without allocating; False behind."""
        R, t = self.R, self.t
        x = R[0, 0] * p[0] + R[0, 1] * p[1] + R[0, 2] * p[2] + t[0]
        y = R[1, 0] * p[0] + R[1, 1] * p[1] + R[1, 2] * p[2] + t[1]
        z = R[2, 0] * p[0] + R[2, 1] * p[1] + R[2, 2] * p[2] + t[2]
        if z <= 0.0:
            out[:] = np.nan
            return False
        out[0] = self.focal_px * x / z + self.principal[0]
        out[1] = self.focal_px * y / z + self.principal[1]
        return True

    @staticmethod
    def to_grid(uv, density):
        """Screen pixels → pixels of the density grid (same shape); ``density`` d or (h, v)."""
        s = SCREEN / np.asarray(density, dtype=float)
        return (np.asarray(uv, dtype=float) - (s - 1) / 2) / s

    @staticmethod
    def to_screen(xy, density):
        """Pixels of the density grid → screen pixels; ``density`` d or (h, v)."""
        s = SCREEN / np.asarray(density, dtype=float)
        return np.asarray(xy, dtype=float) * s + (s - 1) / 2
