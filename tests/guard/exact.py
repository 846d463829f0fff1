"""Exact (rational) geometry for the tests: an independent segment–convex-polygon test and the
mitred offset of a convex polygon, without shapely or the compiled kernels."""
from fractions import Fraction

import numpy as np


def _cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def segment_meets_polygon(a, b, vertices) -> bool:
    """Whether the closed segment a–b and the closed convex polygon (vertices in order) share a
    point, in exact rational arithmetic on the given floats (separating axis theorem)."""
    P = [tuple(map(Fraction, v)) for v in vertices]
    A, B = tuple(map(Fraction, a)), tuple(map(Fraction, b))
    if sum(_cross(P[i], P[(i + 1) % len(P)], P[(i + 2) % len(P)]) for i in range(len(P))) < 0:
        P = P[::-1]  # counter-clockwise
    for i in range(len(P)):
        p, q = P[i], P[(i + 1) % len(P)]
        if _cross(p, q, A) < 0 and _cross(p, q, B) < 0:
            return False  # both ends strictly outside this edge
    side = [_cross(A, B, p) for p in P]
    if A != B and (all(s > 0 for s in side) or all(s < 0 for s in side)):
        return False  # the polygon lies strictly on one side of the segment's line
    if A == B:
        return all(_cross(P[i], P[(i + 1) % len(P)], A) >= 0 for i in range(len(P)))
    # the projections on the segment's direction must overlap
    d = (B[0] - A[0], B[1] - A[1])
    proj = [(p[0] - A[0]) * d[0] + (p[1] - A[1]) * d[1] for p in P]
    return max(proj) >= 0 and min(proj) <= d[0] * d[0] + d[1] * d[1]


def mitred_offset(vertices, m) -> np.ndarray:
    """The convex polygon with every edge pushed out by m (its vertices: where adjacent offset
    edges meet), in floats."""
    v = np.asarray(vertices, float)
    area = 0.5 * np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    if area < 0:
        v = v[::-1]
    e = np.roll(v, -1, axis=0) - v
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / np.hypot(*e.T)[:, None]
    out = []
    for i in range(len(v)):
        n1, n2 = n[i - 1], n[i]  # the edges before and after vertex i
        c1, c2 = n1 @ v[i] + m, n2 @ v[i] + m
        out.append(np.linalg.solve(np.array([n1, n2]), [c1, c2]))
    return np.array(out)
