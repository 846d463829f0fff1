"""Interference zones Ω_I in the joint space Ω (definitions 1 and 2), compiled into half-planes.

A :class:`Zone` is a named union of convex *parts*: a :class:`Box` over any subset of joints
or a convex :class:`Polygon` in the plane of two joints. Every part is an intersection of
open half-spaces ``wᵢ·qᵢ + wⱼ·qⱼ < c`` that each involve at most two joints, with (wᵢ, wⱼ)
a unit vector pointing *out of* the part (a box face has wⱼ = 0). :class:`Scene` compiles a
robot's zones into three tables every algorithm shares — the planners, the feasibility checks
and the compiled per-tick guard:

* ``rows``  float (R, 3): wᵢ, wⱼ, c of each half-plane;
* ``cols``  int (R, 2): the joints i, j of each half-plane;
* ``pieces`` int (P, 3): first row, end row and zone index of each convex part.

The *margin-inflated* part pushes every half-plane out by the margin m (c → c + m): a box
grows by m on every side, a polygon is offset with mitred corners. It contains every point
within Euclidean distance m of the part, and its support line at a corner stays at least m
from the part. ``depth(x) = max over rows of (w·x − c)`` is the distance to the farthest
half-plane boundary: x is inside the inflated part iff depth(x) < m, and depth is
1-Lipschitz, which is what lets a sampled trajectory be certified (rtctl.guard.feasibility).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DEFAULT_RESOLUTION = 0.05  # rad (or m): the n-D planner's grid step
_MITRE_LIMIT = 1e6  # shapely's mitre limit: large enough that every corner keeps its exact mitre


@dataclass(frozen=True, eq=False)
class Box:
    """``lo[k] < q[joints[k]] < hi[k]`` for every k: an axis-aligned box over some joints."""

    joints: tuple[int, ...]
    lo: np.ndarray
    hi: np.ndarray

    def __post_init__(self):
        lo, hi = np.asarray(self.lo, float), np.asarray(self.hi, float)
        object.__setattr__(self, "joints", tuple(int(j) for j in self.joints))
        if not self.joints or len(set(self.joints)) != len(self.joints):
            raise ValueError("a box needs at least one joint, each at most once")
        if lo.shape != (len(self.joints),) or hi.shape != lo.shape:
            raise ValueError(f"a box over {len(self.joints)} joints needs {len(self.joints)} lower and upper bounds")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))) or np.any(lo >= hi):
            raise ValueError("a box needs finite bounds with lo < hi on every joint (else it is degenerate)")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    def halfplanes(self):
        for j, lo, hi in zip(self.joints, self.lo, self.hi):
            yield j, j, 1.0, 0.0, hi
            yield j, j, -1.0, 0.0, -lo


@dataclass(frozen=True, eq=False)
class Polygon:
    """A convex polygon in the plane of ``joints`` = (i, j): vertices (qᵢ, qⱼ) in either order."""

    joints: tuple[int, int]
    vertices: np.ndarray

    def __post_init__(self):
        v = np.asarray(self.vertices, float)
        object.__setattr__(self, "joints", tuple(int(j) for j in self.joints))
        if len(self.joints) != 2 or self.joints[0] == self.joints[1]:
            raise ValueError("a polygon lies in the plane of two different joints")
        if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3 or not np.all(np.isfinite(v)):
            raise ValueError("a polygon needs at least 3 finite vertices (pairs of joint values)")
        edges = np.roll(v, -1, axis=0) - v
        scale = np.abs(v).max() + np.ptp(v, axis=0).max()
        if np.any(np.hypot(*edges.T) <= 1e-12 * scale):
            raise ValueError("a polygon has a repeated vertex (degenerate edge)")
        nxt = np.roll(edges, -1, axis=0)
        cross = edges[:, 0] * nxt[:, 1] - edges[:, 1] * nxt[:, 0]
        area = 0.5 * np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])  # shoelace, signed
        if abs(area) <= 1e-12 * scale * scale:
            raise ValueError("a polygon has no area (degenerate)")
        # convex and simple: every turn the same way, and the turns add up to one full turn
        turning = np.sum(np.arctan2(cross, np.sum(edges * nxt, axis=1)))
        if not (np.all(cross >= 0) or np.all(cross <= 0)) or abs(abs(turning) - 2 * np.pi) > 1e-6:
            raise ValueError("a 'convex' polygon is not convex (or its edges cross): split it into convex parts")
        if area < 0:
            v = v[::-1]
        v.setflags(write=False)
        object.__setattr__(self, "vertices", v)

    def halfplanes(self):
        i, j = self.joints
        v = self.vertices  # counter-clockwise: the outward normal of edge a→b is (dy, −dx)/|e|
        for a, b in zip(v, np.roll(v, -1, axis=0)):
            dx, dy = b - a
            norm = np.hypot(dx, dy)
            wi, wj = dy / norm, -dx / norm
            yield i, j, wi, wj, wi * a[0] + wj * a[1]


@dataclass(frozen=True, eq=False)
class Zone:
    """A named interference zone: the union of its convex parts; ``note`` says what collides."""

    name: str
    parts: tuple
    note: str = ""

    def __post_init__(self):
        object.__setattr__(self, "parts", tuple(self.parts))
        if not self.name or not self.parts or not all(isinstance(p, (Box, Polygon)) for p in self.parts):
            raise ValueError("a zone needs a name and at least one Box or Polygon part")

    @property
    def joints(self) -> tuple[int, ...]:
        return tuple(sorted({j for p in self.parts for j in p.joints}))


@dataclass(frozen=True, eq=False)
class Scene:
    """The zones of one robot with its joint limits and the planning margin m ≥ 0."""

    zones: tuple
    q_min: np.ndarray
    q_max: np.ndarray
    margin: float = 0.0
    joint_names: tuple = ()
    rows: np.ndarray = field(init=False)
    cols: np.ndarray = field(init=False)
    pieces: np.ndarray = field(init=False)
    parts: tuple = field(init=False)  # the part object of each piece

    def __post_init__(self):
        lo, hi = np.asarray(self.q_min, float), np.asarray(self.q_max, float)
        n = lo.shape[0] if lo.ndim == 1 else 0
        if n == 0 or hi.shape != (n,) or np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo >= hi):
            raise ValueError("q_min < q_max, one per joint")
        if not np.isfinite(self.margin) or self.margin < 0:
            raise ValueError(f"margin must be a finite number >= 0, got {self.margin!r}")
        names = tuple(self.joint_names) or tuple(f"joint {j}" for j in range(n))
        if len(names) != n:
            raise ValueError(f"{n} joint names expected")
        zones = tuple(self.zones)
        seen = set()
        for z in zones:
            if z.name in seen:
                raise ValueError(f"zone {z.name!r} is declared twice")
            seen.add(z.name)
            bad = [j for j in z.joints if not 0 <= j < n]
            if bad:
                raise ValueError(f"zone {z.name!r}: joint index {bad[0]} out of range (the robot has {n} joints)")
        rows, cols, pieces, parts = [], [], [], []
        for k, z in enumerate(zones):
            for part in z.parts:
                start = len(rows)
                for i, j, wi, wj, c in part.halfplanes():
                    rows.append((wi, wj, c))
                    cols.append((i, j))
                pieces.append((start, len(rows), k))
                parts.append(part)
        for name, value in (("q_min", lo), ("q_max", hi), ("zones", zones), ("joint_names", names),
                            ("rows", np.array(rows, float).reshape(-1, 3)),
                            ("cols", np.array(cols, np.uint32).reshape(-1, 2)),  # unsigned: no negative-index fix-up per access
                            ("pieces", np.array(pieces, np.uint32).reshape(-1, 3)), ("parts", tuple(parts)),
                            ("margin", float(self.margin))):
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
            object.__setattr__(self, name, value)
        # the kernels' copies: writable, so that a call from Python has the types of the per-tick
        # guard's packed tables and numba compiles each kernel once (the kernels never write them)
        object.__setattr__(self, "_tables", (self.rows.copy(), self.cols.copy(), self.pieces.copy()))

    @property
    def n(self) -> int:
        return self.q_min.shape[0]

    def zone_of_piece(self, piece: int) -> Zone:
        return self.zones[int(self.pieces[piece, 2])]

    def joint_groups(self) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
        """(joints, pieces) of each group of joints linked by zones: the free space is the
        product of the groups' free spaces (and of the untouched joints' ranges)."""
        parent = list(range(self.n))

        def root(j):
            while parent[j] != j:
                parent[j] = parent[parent[j]]
                j = parent[j]
            return j

        for part in self.parts:
            for j in part.joints[1:]:
                parent[root(j)] = root(part.joints[0])
        groups: dict[int, tuple[set, list]] = {}
        for p, part in enumerate(self.parts):
            joints, pieces = groups.setdefault(root(part.joints[0]), (set(), []))
            joints.update(part.joints)
            pieces.append(p)
        return [(tuple(sorted(j)), tuple(p)) for j, p in groups.values()]

    def depth(self, q) -> tuple[float, int]:
        """(smallest piece depth at q, that piece) in numpy — for a few points (configuration
        checks); the compiled :func:`rtctl.guard.kernels.clearance` is the same for many."""
        if len(self.pieces) == 0:
            return np.inf, -1
        per_row = self.rows[:, 0] * q[self.cols[:, 0]] + self.rows[:, 1] * q[self.cols[:, 1]] - self.rows[:, 2]
        per_piece = np.maximum.reduceat(per_row, self.pieces[:, 0].astype(np.intp))
        p = int(np.argmin(per_piece))
        return float(per_piece[p]), p

    def tables(self, pieces=None):
        """(rows, cols, pieces) of all pieces, or of the given piece indices only."""
        rows, cols, all_pieces = self._tables
        if pieces is None:
            return rows, cols, all_pieces
        return rows, cols, np.ascontiguousarray(all_pieces[list(pieces)]).reshape(-1, 3)

    def inflated_shape(self, piece: int, plane: tuple[int, int], margin: float, bounds):
        """The margin-inflated piece in the (q_plane[0], q_plane[1]) plane, as a shapely polygon
        (mitred offset; a one-joint piece is a band across ``bounds`` = (lo0, lo1, hi0, hi1))."""
        import shapely  # planning and plotting only

        part = self.parts[piece]
        margin = margin if margin > 1e-12 else 0.0  # GEOS empties a polygon buffered by a subnormal distance
        if isinstance(part, Polygon):
            v = part.vertices if part.joints == tuple(plane) else part.vertices[:, ::-1]
            return shapely.Polygon(v).buffer(margin, join_style="mitre", mitre_limit=_MITRE_LIMIT)
        lo, hi = np.array(bounds[:2], float), np.array(bounds[2:], float)
        span = hi - lo
        lo, hi = lo - span, hi + span  # a band reaches past the plane's bounds
        for k, j in enumerate(part.joints):
            axis = plane.index(j) if j in plane else -1
            if axis < 0:
                raise ValueError(f"piece {piece} has joint {j} outside the plane {plane}")
            lo[axis], hi[axis] = part.lo[k], part.hi[k]
        return shapely.box(lo[0], lo[1], hi[0], hi[1]).buffer(margin, join_style="mitre", mitre_limit=_MITRE_LIMIT)
