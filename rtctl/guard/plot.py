"""``rtctl plan --plot``: the zones and a path in every joint plane that has a zone.

Each panel shows one plane (qᵢ, qⱼ) within the joint limits: the zones whose parts lie in it
(filled), their margin-inflated outline (dashed), a box over more joints as its projection
(hatched), and the path projected onto the plane. Revolute joints in degrees.
"""
from __future__ import annotations

import math

import numpy as np
import shapely

from rtctl.guard.zones import Box, Scene
from rtctl.plot import _figure_class


def planes(scene: Scene) -> list[tuple[int, int]]:
    """The joint planes the zones are drawn in."""
    out = []
    for part in scene.parts:
        js = part.joints
        if len(js) == 1:
            j = js[0]
            pair = next((p for p in out if j in p), (j, j + 1) if j + 1 < scene.n else (j - 1, j))
        else:
            pair = tuple(sorted(js[:2]))
        if pair not in out:
            out.append(pair)
    return out


def plot_plan(scene: Scene, start, target, path, out, revolute=None, asked=None) -> None:
    """Write a PNG: one panel per plane of :func:`planes`; ``path`` (k × n) may be None;
    ``revolute``: per joint, True to draw it in degrees (default: all); ``asked``: the points
    asked for (start first), drawn joined straight for comparison."""
    revolute = np.ones(scene.n, bool) if revolute is None else np.asarray(revolute, bool)
    Figure = _figure_class()
    panels = planes(scene)
    cols = min(len(panels), 2)
    rows = math.ceil(len(panels) / cols)
    fig = Figure(figsize=(6.0 * cols, 5.5 * rows), layout="constrained")
    for k, plane in enumerate(panels):
        _panel(fig.add_subplot(rows, cols, k + 1), scene, plane, start, target, path, revolute, asked)
    fig.savefig(out, dpi=110)


def _panel(ax, scene: Scene, plane, start, target, path, revolute, asked) -> None:
    i, j = plane
    unit = np.where(revolute[[i, j]], 180.0 / np.pi, 1.0)
    lo = np.where(np.isfinite(scene.q_min[[i, j]]), scene.q_min[[i, j]], -np.pi)
    hi = np.where(np.isfinite(scene.q_max[[i, j]]), scene.q_max[[i, j]], np.pi)
    bounds = (*lo, *hi)
    colours = {}
    for p, part in enumerate(scene.parts):
        zone = scene.zone_of_piece(p)
        colour = colours.setdefault(zone.name, f"C{len(colours) % 10}")
        inside = set(part.joints) <= {i, j}
        projected = isinstance(part, Box) and len(part.joints) > 2 and {i, j} <= set(part.joints)
        if not (inside or projected):
            continue
        raw = _shape(scene, p, plane, 0.0, bounds, projected)
        grown = _shape(scene, p, plane, scene.margin, bounds, projected)
        label = zone.name if zone.name not in ax.get_legend_handles_labels()[1] else None
        for polygon in getattr(raw, "geoms", [raw]):
            if not polygon.is_empty:
                x, y = np.asarray(polygon.exterior.coords).T
                ax.fill(x * unit[0], y * unit[1], alpha=0.35, color=colour, hatch="//" if projected else None,
                        label=label)
                label = None
        for polygon in getattr(grown, "geoms", [grown]):
            if not polygon.is_empty:
                x, y = np.asarray(polygon.exterior.coords).T
                ax.plot(x * unit[0], y * unit[1], ls="--", lw=0.8, color=colour)
    if asked is not None:
        ax.plot(asked[:, i] * unit[0], asked[:, j] * unit[1], ":", color="0.4", lw=1.2, label="straight")
    if path is not None:
        ax.plot(path[:, i] * unit[0], path[:, j] * unit[1], "k.-", lw=1.5, ms=5, label="path")
    ax.plot(start[i] * unit[0], start[j] * unit[1], "go", ms=8, label="start")
    ax.plot(target[i] * unit[0], target[j] * unit[1], "r*", ms=12, label="target")
    ax.set_xlim(lo[0] * unit[0], hi[0] * unit[0])
    ax.set_ylim(lo[1] * unit[1], hi[1] * unit[1])
    u = ["°" if x != 1.0 else "" for x in unit]
    ax.set_xlabel(f"{scene.joint_names[i]} {u[0]}")
    ax.set_ylabel(f"{scene.joint_names[j]} {u[1]}")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")


def _shape(scene, piece, plane, margin, bounds, projected):
    part = scene.parts[piece]
    if not projected:
        return scene.inflated_shape(piece, plane, margin, bounds).intersection(shapely.box(*bounds))
    k = [part.joints.index(x) for x in plane]
    return shapely.box(part.lo[k[0]], part.lo[k[1]], part.hi[k[0]], part.hi[k[1]]).buffer(margin, join_style="mitre")
