"""The guard's geometry, compiled: point depth, segment entry (Cyrus–Beck), the per-tick check.

Tables as compiled by :class:`rtctl.guard.zones.Scene`: ``rows`` (R, 3) = wᵢ, wⱼ, c of each
half-plane ``wᵢ qᵢ + wⱼ qⱼ < c`` (unit normal pointing out of the zone), ``cols`` (R, 2) = i, j,
``pieces`` (P, 3) = first row, end row, zone index (indices unsigned: numba then skips the
negative-index fix-up on every access, which measured 2× in these loops). Everything here works
on preallocated arrays and allocates nothing. ``error_model="numpy"``: no division here can be
by zero (each is guarded), so the kernels carry no exception paths. The row and code constants
live in this module on purpose: numba's cache does not notice edits to other modules a kernel
depends on.
"""
from __future__ import annotations

import numpy as np

from rtctl.compiled import kernel

NO_ENTRY = 2.0  # segment_entry's s when the segment enters nothing (s is in [0, 1])
# rows of the guard's limit table (n columns)
Q_MIN, Q_MAX, DECEL = range(3)
N_LIMIT_ROWS = 3
# the guard's scalar parameters
DT, MARGIN, DAMPING, STIFFNESS, CLAMP = range(5)
N_PARAMS = 5
# rows of the guard's float work table (n columns): the predicted stop point
STOP_POINT = 0
N_WORK_ROWS = 1
# the guard's report (int64 array): what was violated, which zone or joint, which face and piece;
# then one separating-face hint per piece (segment_entry_hinted), initially each piece's first row
KIND, WHICH, FACE, PIECE = range(4)
N_REPORT = 4
NONE, ZONE, UPPER_LIMIT, LOWER_LIMIT = range(4)
# verdicts (rtctl.safety.faults.GuardVerdict) and command modes (rtctl.hal.joints.CommandMode)
PASS, MODIFIED, STOP = 0, 1, 2
IMPEDANCE = 1


@kernel(error_model="numpy")
def piece_depth(rows, cols, r0, r1, x, enough=np.inf):  # pragma: no cover - compiled
    """max over the piece's rows of w·x − c: negative inside the piece, < m inside it inflated by
    m. Stops early once it reaches ``enough`` (the caller only needs to know it is that far)."""
    d = -np.inf
    for r in range(r0, r1):
        v = rows[r, 0] * x[cols[r, 0]] + rows[r, 1] * x[cols[r, 1]] - rows[r, 2]
        if v > d:
            d = v
            if d >= enough:
                return d
    return d


@kernel(error_model="numpy")
def clearance(rows, cols, pieces, x):  # pragma: no cover - compiled
    """(smallest piece depth at x, the first piece with it; +inf and -1 without pieces)."""
    best, which = np.inf, -1
    for p in range(pieces.shape[0]):
        d = piece_depth(rows, cols, pieces[p, 0], pieces[p, 1], x, best)
        if d < best:
            best, which = d, p
    return best, which


@kernel(error_model="numpy")
def clearances(rows, cols, pieces, X, out):  # pragma: no cover - compiled
    """out[k] = smallest piece depth at X[k] (for sampled trajectories)."""
    for k in range(X.shape[0]):
        out[k] = clearance(rows, cols, pieces, X[k])[0]


@kernel(error_model="numpy", inline="always")  # called per face: inlined, a call would cost more than the test
def _outside(rows, cols, r, a, b, margin):  # pragma: no cover - compiled
    """Both ends of a→b lie outside face r of the piece inflated by ``margin``."""
    i, j = cols[r, 0], cols[r, 1]
    edge = rows[r, 2] + margin
    return rows[r, 0] * a[i] + rows[r, 1] * a[j] >= edge and rows[r, 0] * b[i] + rows[r, 1] * b[j] >= edge


@kernel(error_model="numpy")
def separating_face(rows, cols, r0, r1, a, b, margin):  # pragma: no cover - compiled
    """A face of the piece that both ends of a→b lie outside of (the segment then misses the
    piece), or -1. Cheap: no divisions."""
    for r in range(r0, r1):
        if _outside(rows, cols, r, a, b, margin):
            return r
    return -1


@kernel(error_model="numpy")
def clip(rows, cols, r0, r1, a, b, margin):  # pragma: no cover - compiled
    """Cyrus–Beck clipping of a→b against the open piece inflated by ``margin``: (s, row), s in
    [0, 1] where the segment enters (0: a is inside), row the face crossed there (-1 when a is
    inside); (NO_ENTRY, -1) when it stays out."""
    s_lo, s_hi, face = 0.0, 1.0, -1
    for r in range(r0, r1):
        i, j = cols[r, 0], cols[r, 1]
        wi, wj = rows[r, 0], rows[r, 1]
        room = rows[r, 2] + margin - (wi * a[i] + wj * a[j])  # > 0: a is on the inner side
        rate = wi * (b[i] - a[i]) + wj * (b[j] - a[j])
        if room <= 0.0:
            if rate >= 0.0 or room <= rate:  # never reaches the inner side for s in [0, 1)
                return NO_ENTRY, -1
            s = room / rate  # reaches the inner side at s
            if s > s_lo:
                s_lo, face = s, r
        elif rate > 0.0:
            s = room / rate  # leaves the inner side at s
            if s < s_hi:
                s_hi = s
        if s_lo >= s_hi:
            return NO_ENTRY, -1
    return s_lo, face


@kernel(error_model="numpy")
def piece_entry(rows, cols, r0, r1, a, b, margin):  # pragma: no cover - compiled
    """Where a→b enters the open piece inflated by ``margin``: see :func:`clip`."""
    if separating_face(rows, cols, r0, r1, a, b, margin) >= 0:
        return NO_ENTRY, -1
    return clip(rows, cols, r0, r1, a, b, margin)


@kernel(error_model="numpy")
def segment_entry(rows, cols, pieces, a, b, margin):  # pragma: no cover - compiled
    """The first entry of a→b into any piece inflated by ``margin``: (s, piece, face row);
    (NO_ENTRY, -1, -1) when the segment stays outside all of them."""
    best, which, face = NO_ENTRY, -1, -1
    for p in range(pieces.shape[0]):
        s, r = piece_entry(rows, cols, pieces[p, 0], pieces[p, 1], a, b, margin)
        if s < best:
            best, which, face = s, p, r
    return best, which, face


@kernel(error_model="numpy")
def segment_entry_hinted(rows, cols, pieces, a, b, margin, hints):  # pragma: no cover - compiled
    """:func:`segment_entry` for a segment that moves little between calls (the per-tick
    stopping path): ``hints[p]`` remembers the face that separated piece p last time, which
    usually still does — one test per piece away from the robot."""
    best, which, face = NO_ENTRY, -1, -1
    for p in range(pieces.shape[0]):
        r0, r1 = pieces[p, 0], pieces[p, 1]
        if _outside(rows, cols, hints[p], a, b, margin):
            continue
        r = separating_face(rows, cols, r0, r1, a, b, margin)
        if r >= 0:
            hints[p] = r
            continue
        s, r = clip(rows, cols, r0, r1, a, b, margin)
        if s < best:
            best, which, face = s, p, r
    return best, which, face


@kernel(error_model="numpy")
def _push_out(i, j, wi, wj, depth, q, qd, q_des, qd_des, tau, mode, par):  # pragma: no cover - compiled
    """Clamp along the outward unit normal (wi at joint i, wj at joint j; i == j with wj = 0
    for a box face or a limit): drop the command's inward component and add a wall force,
    stiffness × ``depth`` (how far the predicted stop point lies inside the band, which grows
    with the inward speed squared) + damping × inward speed. Impedance mode: the drive also
    holds the current position of these joints and gets no inward velocity."""
    inward_speed = wi * qd[i] + wj * qd[j]
    push = wi * tau[i] + wj * tau[j]
    if push < 0.0:
        tau[i] -= push * wi
        tau[j] -= push * wj
    wall = par[STIFFNESS] * depth - par[DAMPING] * min(inward_speed, 0.0)
    tau[i] += wall * wi
    tau[j] += wall * wj
    if mode == IMPEDANCE:
        q_des[i] = q[i]
        q_des[j] = q[j]
        v = wi * qd_des[i] + wj * qd_des[j]
        if v < 0.0:
            qd_des[i] -= v * wi
            qd_des[j] -= v * wj


@kernel(error_model="numpy")
def guard_tick(q, qd, mode, q_des, qd_des, tau, rows, cols, pieces, lim, par, work, report, hints):  # pragma: no cover
    """The run-time guard for one tick; returns PASS, MODIFIED or STOP and fills ``report``.

    Predicted motion: the command acts for one period dt, then every joint brakes at a common
    rate so that none exceeds its deceleration limit (a straight stopping path): stop time
    T = max_j |q̇_j| / a_j, stop point p = q + q̇ (dt + T/2). The segment q→p (and in
    impedance mode q→q_des) must stay out of every zone inflated by the guard margin g and
    inside the joint limits; the first violation met along q→p is reported.

    Without CLAMP a violation is a STOP. With CLAMP the guard margin is two bands, like the
    safety stage's soft and hard limits: a stopping path that enters the outer half
    (zone ⊕ g, or within g/2 of a limit) is clamped — the command is pushed out along every
    face that separates q from the zone (:func:`_push_out`) — and one that reaches the inner
    half (zone ⊕ g/2, or past a limit) is a STOP, early enough for the fallback to brake.
    ``par``: DT, MARGIN (g), DAMPING and STIFFNESS of the clamp's wall, CLAMP. ``hints``: see
    :func:`segment_entry_hinted`. ``report``: KIND, and for a violation WHICH zone (or joint),
    FACE and PIECE (unsigned: only meaningful with the KIND that sets them).
    """
    n = q.shape[0]
    dt, margin, clamp = par[DT], par[MARGIN], par[CLAMP] != 0.0
    limit_band = 0.5 * margin if clamp else 0.0
    t_stop = 0.0
    for j in range(n):
        t = abs(qd[j]) / lim[DECEL, j]
        if t > t_stop:
            t_stop = t
    p = work[STOP_POINT]
    for j in range(n):
        p[j] = q[j] + qd[j] * (dt + 0.5 * t_stop)
    s, piece, face = segment_entry_hinted(rows, cols, pieces, q, p, margin, hints)
    report[KIND] = NONE
    if s < NO_ENTRY:
        report[KIND], report[WHICH], report[FACE], report[PIECE] = ZONE, pieces[piece, 2], face, piece
    stop = False
    for j in range(n):  # a limit met before the zone counts first
        hi, lo = lim[Q_MAX, j] - limit_band, lim[Q_MIN, j] + limit_band
        if p[j] > hi or p[j] < lo:
            stop = stop or p[j] > lim[Q_MAX, j] or p[j] < lim[Q_MIN, j]
            bound = hi if p[j] > hi else lo
            sj = 0.0 if p[j] == q[j] else min(max((bound - q[j]) / (p[j] - q[j]), 0.0), 1.0)
            if sj < s:
                s = sj
                report[KIND] = UPPER_LIMIT if p[j] > hi else LOWER_LIMIT
                report[WHICH] = j
    if mode == IMPEDANCE and report[KIND] == NONE:
        s_des, piece, face = segment_entry(rows, cols, pieces, q, q_des, margin)
        if s_des < NO_ENTRY:
            report[KIND], report[WHICH], report[FACE], report[PIECE] = ZONE, pieces[piece, 2], face, piece
    if report[KIND] == NONE:
        return PASS
    if not clamp or stop or segment_entry(rows, cols, pieces, q, p, 0.5 * margin)[0] < NO_ENTRY:
        return STOP
    if report[KIND] == ZONE:  # push out along every face that separates q from the inner band
        piece = report[PIECE]
        for r in range(pieces[piece, 0], pieces[piece, 1]):
            i, j, wi, wj = cols[r, 0], cols[r, 1], rows[r, 0], rows[r, 1]
            if wi * q[i] + wj * q[j] >= rows[r, 2] + 0.5 * margin:
                depth = max(rows[r, 2] + margin - (wi * p[i] + wj * p[j]), 0.0)
                _push_out(i, j, wi, wj, depth, q, qd, q_des, qd_des, tau, mode, par)
    else:
        j = report[WHICH]
        upper = report[KIND] == UPPER_LIMIT
        depth = max(p[j] - lim[Q_MAX, j] + limit_band, 0.0) if upper else max(lim[Q_MIN, j] + limit_band - p[j], 0.0)
        _push_out(j, j, -1.0 if upper else 1.0, 0.0, depth, q, qd, q_des, qd_des, tau, mode, par)
    return MODIFIED



# ---- the per-tick call, packed: numba's dispatcher costs about as much per argument as the
# ---- check itself, so the guard's tables travel as two flat arrays, each table a contiguous
# ---- block of them. Viewed as C-contiguous 2-D arrays inside, they have the types the tables
# ---- have when the planners call the same kernels from Python: each kernel compiles once.
def _layout(R: int, P: int, n: int):
    """Offsets (float blocks: rows, lim, par, work; uint32 blocks: cols, pieces, hints, report)
    and the two buffers' lengths; the uint32 buffer starts with the header R, P."""
    f = np.cumsum([0, 3 * R, N_LIMIT_ROWS * n, N_PARAMS, N_WORK_ROWS * n])
    u = np.cumsum([2, 2 * R, 3 * P, P, N_REPORT])
    return f, u


def pack(rows, cols, pieces, lim, par, work, report):
    """(F, I, views): F float holds rows, lim, par and work; I uint32 holds a header (R, P),
    cols, pieces, the separating-face hints (initially each piece's first row) and the report.
    ``views`` = (rows, cols, pieces, lim, par, work, report, hints) into them, for the caller to
    read and write."""
    R, P, n = rows.shape[0], pieces.shape[0], lim.shape[1]
    f, u = _layout(R, P, n)
    F, I = np.zeros(f[-1]), np.zeros(u[-1], dtype=np.uint32)
    I[:2] = R, P
    views = (F[f[0]:f[1]].reshape(R, 3), I[u[0]:u[1]].reshape(R, 2), I[u[1]:u[2]].reshape(P, 3),
             F[f[1]:f[2]].reshape(N_LIMIT_ROWS, n), F[f[2]:f[3]], F[f[3]:f[4]].reshape(N_WORK_ROWS, n),
             I[u[3]:u[4]], I[u[2]:u[3]])
    for view, value in zip(views, (rows, cols, pieces, lim, par, work, report[:N_REPORT], pieces[:, 0])):
        view[...] = value
    return F, I, views


@kernel(error_model="numpy")
def guard_tick_packed(q, qd, mode, q_des, qd_des, tau, F, I):  # pragma: no cover - compiled
    """:func:`guard_tick` on the buffers of :func:`pack` (the same layout as :func:`_layout`)."""
    R, P, n = np.int64(I[0]), np.int64(I[1]), q.shape[0]
    f1, f2 = 3 * R, 3 * R + N_LIMIT_ROWS * n
    f3 = f2 + N_PARAMS
    u1, u2 = 2 + 2 * R, 2 + 2 * R + 3 * P
    u3 = u2 + P
    return guard_tick(q, qd, mode, q_des, qd_des, tau, F[:f1].reshape((R, 3)), I[2:u1].reshape((R, 2)),
                      I[u1:u2].reshape((P, 3)), F[f1:f2].reshape((N_LIMIT_ROWS, n)), F[f2:f3],
                      F[f3:f3 + N_WORK_ROWS * n].reshape((N_WORK_ROWS, n)), I[u3:u3 + N_REPORT], I[u2:u3])
