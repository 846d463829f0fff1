"""Build joint trajectories: point-to-point, through waypoints (stopping or smooth), retarget.

Every constructor takes plain values (sequences of floats, radians or metres), so a parsed
TOML table can be passed as it is, and returns a :class:`JointTrajectory` that never
exceeds the :class:`JointLimits` — checked with the exact extrema of every segment; a
request that cannot be met (duration too short, waypoint out of range) raises
:class:`~rtctl.errors.TrajectoryError` saying why.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rtctl.errors import TrajectoryError
from rtctl.trajectory.piecewise import JointTrajectory
from rtctl.trajectory.quintic import (braking_target, coefficients, constant, extrema, fits,
                                      rest_to_rest_duration, shortest_duration)
from rtctl.trajectory.smooth import fit_durations, run_coefficients

_RTOL = 1e-9
# the longest segment (11.6 days): a quintic over 1e300 s overflows, and its figures read nan
MAX_DURATION_S = 1e6
_SAME_POINT = 1e-12  # rad or m: points at most this far apart count as one (no segment between them)


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Per-joint velocity and acceleration limits (> 0) and optional position limits."""

    v_max: np.ndarray
    a_max: np.ndarray
    q_min: np.ndarray | None = None
    q_max: np.ndarray | None = None

    def __post_init__(self):
        v, a = np.asarray(self.v_max, float), np.asarray(self.a_max, float)
        if v.ndim != 1 or v.shape != a.shape or not (np.all(v > 0) and np.all(a > 0)):
            raise TrajectoryError("v_max and a_max must be positive, one per joint")
        object.__setattr__(self, "v_max", v)
        object.__setattr__(self, "a_max", a)
        if (self.q_min is None) != (self.q_max is None):
            raise TrajectoryError("give both q_min and q_max, or neither")
        if self.q_min is not None:
            lo, hi = np.asarray(self.q_min, float), np.asarray(self.q_max, float)
            if lo.shape != v.shape or hi.shape != v.shape or np.any(lo >= hi):
                raise TrajectoryError("q_min < q_max, one per joint")
            object.__setattr__(self, "q_min", lo)
            object.__setattr__(self, "q_max", hi)

    @classmethod
    def from_model(cls, model, a_max, velocity_scale: float = 1.0) -> "JointLimits":
        """The model's velocity limits (scaled) and joint range, with the given accelerations."""
        return cls(model.v_max * velocity_scale, np.broadcast_to(np.asarray(a_max, float), (model.nq,)),
                   model.q_min, model.q_max)

    @classmethod
    def for_run(cls, model, trajectory=None) -> "JointLimits":
        """What a run plans with (its trajectory and every ``move``): the model's velocity limits
        (1 rad/s where it has none) times the ``[trajectory]`` table's ``velocity_scale`` (0.5
        without one), its ``max_acceleration`` (5 rad/s² without), the model's joint range."""
        scale = trajectory.velocity_scale if trajectory is not None else 0.5
        v = np.where(np.isfinite(model.v_max), model.v_max, 1.0) * scale
        a = trajectory.max_acceleration if trajectory is not None and trajectory.max_acceleration is not None \
            else np.full(model.nq, 5.0)
        return cls(v, a, model.q_min, model.q_max)

    @property
    def n(self) -> int:
        return len(self.v_max)

    def check_position(self, q, what: str) -> None:
        if self.q_min is None:
            return
        bad = np.flatnonzero((q < self.q_min) | (q > self.q_max))
        if len(bad):
            j = bad[0]
            raise TrajectoryError(f"{what}: joint {j} at {q[j]:.6g} is outside [{self.q_min[j]:.6g}, {self.q_max[j]:.6g}]")


def hold(q, t0: float = 0.0) -> JointTrajectory:
    """Stay at ``q`` from ``t0`` on."""
    return JointTrajectory([t0, t0], constant(np.asarray(q, float))[None])


def point_to_point(q0, q1, limits: JointLimits, duration: float | None = None, t0: float = 0.0) -> JointTrajectory:
    """Synchronised min-jerk move from rest at ``q0`` to rest at ``q1``: the shortest duration
    within the limits (closed form, see :mod:`~rtctl.trajectory.quintic`), or the requested
    ``duration`` if that is longer (a shorter one raises)."""
    return through_waypoints([q1], limits, start=q0, durations=None if duration is None else [duration], t0=t0)


def through_waypoints(waypoints, limits: JointLimits, *, start=None, smooth: bool = False, dwell=0.0,
                      durations=None, t0: float = 0.0) -> JointTrajectory:
    """Through ``waypoints`` (m × n) from ``start`` (e.g. the measured position; default: the
    first waypoint), then hold the last one.

    ``smooth=False`` stops at every waypoint (one min-jerk segment each, shortest duration);
    ``smooth=True`` passes through them (:mod:`~rtctl.trajectory.smooth`) and stops only at
    the ends, at repeated points and where ``dwell`` > 0. ``dwell``: seconds to wait at each
    waypoint (a scalar or one per waypoint). ``durations``: one per segment (segment k joins
    point k to point k + 1) — in stop mode each entry is a duration or None (shortest), one
    below the limits' minimum raises and one between a repeated point and itself is a wait;
    in smooth mode all of them or none.
    """
    W = np.atleast_2d(np.asarray(waypoints, float))
    if W.shape[1] != limits.n or len(W) == 0:
        raise TrajectoryError(f"waypoints must be (m, {limits.n}), got {W.shape}")
    _check_durations(durations)
    first = 0 if start is None else 1
    points = W if start is None else np.vstack([np.asarray(start, float), W])
    if not np.all(np.isfinite(points)):
        raise TrajectoryError("waypoints and start must be finite")
    for k, p in enumerate(points):
        limits.check_position(p, "start" if k < first else f"waypoint {k - first}")
    dwell_at = np.zeros(len(points))
    dwell_at[first:] = np.broadcast_to(np.asarray(dwell, float), (len(W),))
    if np.any(dwell_at < 0):
        raise TrajectoryError("dwell times must be >= 0")
    n_seg = len(points) - 1
    if durations is not None and len(durations) != n_seg:
        raise TrajectoryError(f"{n_seg} motion segments but {len(durations)} durations")

    moving = np.max(np.abs(np.diff(points, axis=0)), axis=1) > _SAME_POINT  # False for a repeated point
    stop = np.ones(len(points), dtype=bool)
    if smooth:
        stop[1:-1] = (dwell_at[1:-1] > 0) | ~moving[:-1] | ~moving[1:]
    T_all, C_all = [], []
    for a in range(n_seg + 1):
        if dwell_at[a] > 0:
            T_all.append(dwell_at[a])
            C_all.append(constant(points[a]))
        if a < n_seg and stop[a] and moving[a]:
            b = a + 1 + int(np.argmax(stop[a + 1:]))  # the next stop point
            T, C = _run(points[a:b + 1], limits, None if durations is None else durations[a:b], a)
            T_all.extend(T)
            C_all.extend(C)
        elif a < n_seg and not moving[a] and durations is not None and durations[a]:
            if not durations[a] > 0:
                raise TrajectoryError(f"segment {a}: duration {durations[a]:.6g} s must be positive")
            T_all.append(float(durations[a]))  # the same point twice, a time apart: wait there
            C_all.append(constant(points[a]))
    if not T_all:
        return hold(points[-1], t0)
    return JointTrajectory.from_segments(t0, T_all, np.array(C_all))


def _run(points, limits, requested, first_segment):
    """Durations and coefficients of the segments between two stop points."""
    if len(points) == 2:  # one rest-to-rest segment
        t_min = rest_to_rest_duration(points[1] - points[0], limits.v_max, limits.a_max)
        T = t_min if requested is None or requested[0] is None else float(requested[0])
        if T < t_min * (1 - _RTOL):
            raise TrajectoryError(f"segment {first_segment}: duration {T:.6g} s is below the "
                                  f"{t_min:.6g} s the velocity/acceleration limits need")
        return [T], [coefficients(points[0], 0.0, 0.0, points[1], 0.0, 0.0, T)]
    if requested is None or all(r is None for r in requested):
        T = fit_durations(points, limits.v_max, limits.a_max)
    elif any(r is None for r in requested):
        raise TrajectoryError("smooth trajectories take all segment durations or none")
    else:
        T = np.asarray(requested, float)
    C = run_coefficients(points, T)
    for k in range(len(T)):
        _check(C[k], T[k], limits, first_segment + k)
    return list(T), list(C)


def _check_durations(durations) -> None:
    """Requested durations (None entries: the shortest) must lie in (0, MAX_DURATION_S]."""
    if durations is None:
        return
    for k, T in enumerate(durations):
        if T is not None and not 0 < T <= MAX_DURATION_S:
            raise TrajectoryError(f"duration {k}: {T:.6g} s must be positive and at most {MAX_DURATION_S:g} s")


def _check(c, T, limits, segment):
    """Refuse a segment (an index, or a label such as "the move to waypoint 0") that breaks the limits."""
    segment = segment if isinstance(segment, str) else f"segment {segment}"
    if not 0 < T <= MAX_DURATION_S:
        raise TrajectoryError(f"{segment}: duration {T:.6g} s must be positive and at most {MAX_DURATION_S:g} s")
    if fits(c, T, limits.v_max, limits.a_max, limits.q_min, limits.q_max):
        return
    e = extrema(c, T)
    detail = f"peak |q̇|/v_max {np.max(e[2] / limits.v_max):.4g}, |q̈|/a_max {np.max(e[3] / limits.a_max):.4g}"
    if limits.q_min is not None:
        detail += f", range [{', '.join(f'{x:.4g}' for x in e[0])}] .. [{', '.join(f'{x:.4g}' for x in e[1])}]"
    raise TrajectoryError(f"{segment}: duration {T:.6g} s violates the limits ({detail})")


def _brake_then_move(q, qd, qdd, q1, limits, duration=None):
    """Two moves (duration, end): brake to rest in the shortest time within the limits, then
    go from rest to ``q1`` — in the shortest time, or in what is left of ``duration`` (when
    nothing is left, the requested time cannot be met)."""
    T = shortest_duration(q, qd, qdd, None, limits.v_max, limits.a_max, limits.q_min, limits.q_max)
    if T is None:
        raise TrajectoryError("no duration brings the current motion to rest within the limits")
    q_stop = braking_target(q, qd, qdd, T)
    if duration is None:
        rest = rest_to_rest_duration(q1 - q_stop, limits.v_max, limits.a_max)
        return [(T, q_stop)] + ([(rest, q1)] if rest > 0.0 else [])
    if duration <= T:
        raise TrajectoryError(f"the move to waypoint 0: duration {duration:.6g} s violates the limits (the "
                              f"current motion needs {T:.6g} s to come to rest within them)")
    return [(T, q_stop), (duration - T, q1)]


def retarget(t: float, q, qd, qdd, waypoints, limits: JointLimits, *, duration: float | None = None,
             durations=None, smooth: bool = False, dwell=0.0) -> JointTrajectory:
    """Replace the running trajectory at time ``t`` (the control socket's ``move``): from the
    current reference state (``q``, ``qd``, ``qdd`` — position, velocity and acceleration stay
    continuous) to rest at the first waypoint, then on through the others as
    :func:`through_waypoints` would.

    The first move is one quintic in the shortest duration within the limits (closed form
    from rest, else :func:`~rtctl.trajectory.quintic.shortest_duration`) or in the requested
    ``duration`` (braking first, as below, when one quintic from the current motion cannot take
    that long within the limits; the move from rest gets the rest of the time). When no single
    quintic fits (a fast joint must stop while another barely
    moves), it brakes first — to :func:`~rtctl.trajectory.quintic.braking_target` — and then
    moves from rest. ``durations`` (one per later segment, as :func:`through_waypoints`
    takes them: segment k joins waypoint k to k + 1) time the rest of the way. Raises
    :class:`~rtctl.errors.TrajectoryError` when even braking cannot stay within the limits, or
    when a requested duration does not (the message names the segment and the limit).
    """
    q, qd, qdd = (np.asarray(x, float) for x in (q, qd, qdd))
    W = np.atleast_2d(np.asarray(waypoints, float))
    _check_durations(None if duration is None else [duration])
    limits.check_position(q, "start")
    rest = through_waypoints(W, limits, smooth=smooth, dwell=dwell, durations=durations)  # validates the waypoints
    at_rest = not (np.any(qd) or np.any(qdd))
    T_all, C_all = ([], []) if rest.duration == 0.0 else (list(np.diff(rest.knots)), list(rest.coeffs))
    lim = (limits.v_max, limits.a_max, limits.q_min, limits.q_max)
    if at_rest:
        T = float(duration) if duration is not None else rest_to_rest_duration(W[0] - q, limits.v_max, limits.a_max)
        moves = [] if duration is None and T == 0.0 else [(T, W[0])]  # from rest at W[0]: nothing to do
    elif duration is not None:
        moves = [(float(duration), W[0])]
        if not fits(coefficients(q, qd, qdd, W[0], 0.0, 0.0, duration), duration, *lim):
            moves = _brake_then_move(q, qd, qdd, W[0], limits, duration)
    else:
        T = shortest_duration(q, qd, qdd, W[0], *lim)
        moves = [(T, W[0])] if T is not None else _brake_then_move(q, qd, qdd, W[0], limits)
    T_first, C_first, start = [], [], (q, qd, qdd)
    for (T, end), label in zip(moves, ["braking", "the move to waypoint 0"][2 - len(moves):]):
        c = coefficients(*start, end, 0.0, 0.0, T)
        _check(c, T, limits, label)
        T_first.append(T)
        C_first.append(c)
        start = (end, 0.0, 0.0)
    if not T_first and not T_all:
        return hold(W[0], t)
    return JointTrajectory.from_segments(t, T_first + T_all, np.array(C_first + C_all))
