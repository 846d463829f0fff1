"""``[guard]`` and ``[[guard.zones]]``: interference zones from the robot file and the run configuration.

A D-H robot file may declare the zones that belong to the robot (in its ``angle_unit``); a
run configuration may add zones of its work cell and sets how the guard acts::

    [guard]
    unit = "deg"                  # of every angle below (prismatic joints: metres); default "rad"
    margin = 3.0                  # planned paths keep this far from every zone (robot file: default)
    guard_margin = 0.5            # the run-time guard acts this far out (0 … margin/2)
    action = "stop"               # or "clamp": slide along the zone instead of stopping
    deceleration = 1000.0         # °/s² (one, or one per joint) the stopping path may assume
                                  # (default: the trajectory's acceleration limits)
    resolution = 2.0              # the n-D planner's grid step
    move_budget = 2000            # grid nodes a `move` may search inside the loop
    plan_budget = 100000          # grid nodes `plan`, `check` and `run` may search per leg

    [[guard.zones]]
    name = "forearm_vs_pedestal"  # unique; named by every report and event
    note = "what collides"
    joints = ["shoulder", "elbow"]  # names, or indices from 0
    polygon = [[-45, -225], [-45, -143], [23, -225]]   # convex, in (shoulder, elbow)
    # or a box:   lo = [...]  hi = [...]     (one bound per joint)
    # or a union: [[guard.zones.parts]] tables, each a polygon or a box as above

Everything is validated before any device is touched; an error names the file, the key
path, the zone and what was expected (:class:`~rtctl.errors.ConfigError`, exit 2).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rtctl.errors import ConfigError
from rtctl.guard.zones import DEFAULT_RESOLUTION, Box, Polygon, Scene, Zone
from rtctl.tomltable import Table, load_toml

DEFAULT_MARGIN = 0.05  # rad
DEFAULT_MOVE_BUDGET = 2000
DEFAULT_PLAN_BUDGET = 100_000  # ≈ 5-6 s of grid search on the 2-core VM: an offline plan always answers


@dataclass(frozen=True, eq=False)
class GuardConfig:
    scene: Scene
    guard_margin: float
    action: str
    deceleration: np.ndarray | None  # per joint; None: the trajectory's acceleration limits
    resolution: float
    move_budget: int
    plan_budget: int


def load_guard(run: Table | None, robot_file: Path, model) -> GuardConfig | None:
    """The guard of a run: zones of the robot file and of ``run`` (its ``[guard]`` table);
    None when neither declares a guard."""
    robot = _robot_guard(robot_file)
    if robot is None and run is None:
        return None
    zones, margin = [], DEFAULT_MARGIN
    if robot is not None:
        guard_t, unit = robot
        margin = guard_t.float("margin", DEFAULT_MARGIN / _angle(unit), min=0.0) * _angle(unit)
        zones += _zones(guard_t, model, unit_scale(model, unit))
        guard_t.done()
    settings = {}
    if run is not None:
        unit = run.str("unit", "rad", choices=("deg", "rad"))
        scale, ang = unit_scale(model, unit), _angle(unit)
        margin = run.float("margin", margin / ang, min=0.0) * ang
        settings = {
            "guard_margin": run.float("guard_margin", 0.2 * margin / ang, min=0.0) * ang,
            "action": run.str("action", "stop", choices=("stop", "clamp")),
            "deceleration": _deceleration(run, model, scale),
            "resolution": run.float("resolution", DEFAULT_RESOLUTION / ang, positive=True) * ang,
            "move_budget": run.int("move_budget", DEFAULT_MOVE_BUDGET, min=1),
            "plan_budget": run.int("plan_budget", DEFAULT_PLAN_BUDGET, min=1),
        }
        zones += _zones(run, model, scale)
        if settings["guard_margin"] > 0.5 * margin:
            raise run.error("guard_margin", f"at most half the margin ({0.5 * margin / ang:g} {unit}): planned "
                                            f"paths may use the other half, the guard must not stop them")
        if settings["action"] == "clamp" and settings["guard_margin"] == 0:
            raise run.error("guard_margin", "> 0 with action = \"clamp\" (it clamps in the outer half, stops in the inner)")
        run.done()
    names = [z.name for z, _ in zones]
    for i, (z, where) in enumerate(zones):
        if z.name in names[:i]:
            raise where.error("name", f"a unique zone name; {z.name!r} is declared twice")
    scene = Scene(tuple(z for z, _ in zones), model.q_min, model.q_max, margin, model.joint_names)
    return GuardConfig(scene, settings.get("guard_margin", 0.2 * margin), settings.get("action", "stop"),
                       settings.get("deceleration"), settings.get("resolution", DEFAULT_RESOLUTION),
                       settings.get("move_budget", DEFAULT_MOVE_BUDGET), settings.get("plan_budget", DEFAULT_PLAN_BUDGET))


def _robot_guard(robot_file: Path):
    """(the robot file's [guard] table, its angle unit), or None."""
    if Path(robot_file).suffix != ".toml":
        return None
    t = load_toml(robot_file)
    guard = t.table("guard", None)
    return None if guard is None else (guard, t.data.get("angle_unit", "rad"))


def _angle(unit: str) -> float:
    return np.pi / 180.0 if unit == "deg" else 1.0


def unit_scale(model, unit: str) -> np.ndarray:
    """Per joint: the factor from the file's unit to rad (revolute) or m (prismatic)."""
    return np.where(model.joint_types == 0, _angle(unit), 1.0)


def _deceleration(t: Table, model, scale):
    if not t.has("deceleration"):
        t.raw("deceleration", None)
        return None
    if isinstance(t.raw("deceleration"), list):
        value = t.vector("deceleration", model.nq)
        if np.any(value <= 0):
            raise t.error("deceleration", "positive numbers")
    else:
        value = np.full(model.nq, t.float("deceleration", positive=True))
    return value * scale


def _zones(t: Table, model, scale) -> list[tuple[Zone, Table]]:
    out = []
    for z in t.tables("zones", []):
        name = z.str("name")
        note = z.str("note", "")
        parts_t = z.tables("parts", None)
        if parts_t is None:
            parts = [zone_part(z, name, model, scale)]
        else:
            if not parts_t:
                raise z.error("parts", f"zone {name!r}: at least one [[…parts]] table")
            parts = [zone_part(p, name, model, scale) for p in parts_t]
            for p in parts_t:
                p.done()
        z.done()
        try:
            out.append((Zone(name, tuple(parts), note), z))
        except ValueError as e:
            raise z.error("name", f"zone {name!r}: {e}") from None
    return out


def zone_part(t: Table, zone: str, model, scale):
    """One part of a zone: ``joints`` and a ``polygon`` (two joints) or a ``lo``/``hi`` box,
    in the file's unit (``scale``: :func:`unit_scale`); also a shared zone's region of one
    robot (:mod:`rtctl.cell.config`)."""
    joints = _joints(t, zone, model)
    has_polygon, has_box = t.has("polygon"), t.has("lo") or t.has("hi")
    if has_polygon == has_box:
        raise t.error("polygon", f"zone {zone!r}: either polygon = [[…], …] (two joints) or lo/hi (a box)")
    try:
        if has_polygon:
            raw = t.raw("polygon")
            ok = isinstance(raw, list) and all(
                isinstance(v, list) and len(v) == 2 and all(_number(x) for x in v) for v in raw)
            if not ok:
                raise t.error("polygon", f"zone {zone!r}: an array of [{_pair(model, joints)}] pairs of finite numbers")
            if len(joints) != 2:
                raise t.error("joints", f"zone {zone!r}: a polygon lies in the plane of exactly two joints")
            return Polygon(joints, np.array(raw, float) * scale[list(joints)])
        lo, hi = t.vector("lo", len(joints)), t.vector("hi", len(joints))
        return Box(joints, lo * scale[list(joints)], hi * scale[list(joints)])
    except ValueError as e:
        raise t.error("polygon" if has_polygon else "lo", f"zone {zone!r}: {e}") from None


def _joints(t: Table, zone: str, model) -> tuple[int, ...]:
    raw = t.raw("joints", None)
    if not isinstance(raw, list) or not raw:
        raise t.error("joints", f"zone {zone!r}: a non-empty array of joint names or indices")
    out = []
    for x in raw:
        if isinstance(x, str):
            if x not in model.joint_names:
                raise t.error("joints", f"zone {zone!r}: joint names of {model.name} "
                                        f"({', '.join(model.joint_names)}); unknown: {x!r}")
            out.append(model.joint_names.index(x))
        elif isinstance(x, int) and not isinstance(x, bool):
            if not 0 <= x < model.nq:
                raise t.error("joints", f"zone {zone!r}: joint index {x} out of range ({model.name} has "
                                        f"{model.nq} joints: 0 … {model.nq - 1})")
            out.append(x)
        else:
            raise t.error("joints", f"zone {zone!r}: joint names or indices, got {x!r}")
    if len(set(out)) != len(out):
        raise t.error("joints", f"zone {zone!r}: each joint at most once")
    return tuple(out)


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)


def _pair(model, joints) -> str:
    return ", ".join(model.joint_names[j] for j in joints)


def check_waypoints(t: Table, guard: GuardConfig | None, waypoints) -> None:
    """ConfigError naming the first trajectory waypoint inside a zone or its margin, and listing
    every other one (an operator fixes them all at once)."""
    if guard is None:
        return
    scene, bad = guard.scene, []
    for k, w in enumerate(waypoints):
        depth, piece = scene.depth(w)
        if depth < scene.margin:
            where = "inside" if depth < 0 else "within the margin of"
            bad.append((k, f"{where} zone {scene.zone_of_piece(piece).name!r}"))
    if bad:
        (k, why), others = bad[0], bad[1:]
        also = f" (also infeasible: {'; '.join(f'waypoints[{i}] {w}' for i, w in others)})" if others else ""
        raise ConfigError(t.file, f"{t.key('waypoints')}[{k}]", f"a feasible configuration, but it is {why}{also}")
