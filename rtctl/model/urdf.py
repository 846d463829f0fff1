"""URDF ⇄ Model for serial chains of revolute, continuous and prismatic joints.

Reading (:func:`load_urdf`, :func:`parse_urdf`):

* body ``i`` is the child link of the ``i``-th moving joint (depth-first from the root link),
  so body frames are Pinocchio's joint frames; its tree placement is the joint's
  ``<origin>`` composed with every fixed joint between it and the previous moving joint;
* links hanging on fixed joints are merged into the body they hang on: their inertias,
  moved into the body frame, are added (the 10 parameters are linear in the mass
  distribution); links fixed to the root are part of the base and carry no dynamics;
* joints named in ``lock`` (name → position) are treated as fixed at that position (e.g. a
  gripper's fingers), as Pinocchio's ``buildReducedModel`` does;
* the flange is the end of the run of single fixed links after the last moving joint
  (or ``flange_link``); a trailing link called ``tool`` becomes the tool frame, which is how
  :func:`to_urdf` writes it, so the two round-trip;
* limits: ``lower``/``upper`` (±∞ for continuous joints), ``velocity``, ``effort``.

Writing (:func:`to_urdf`): the base → link ``base_link``, body ``i`` (from 0) → link
``link{i + 1}`` and joint ``i`` with the tree placement as origin and its axis and limits; a
fixed ``flange`` link on the last body and a fixed ``tool`` link on the flange, so
Pinocchio's placement of frame ``tool`` (type BODY) is our tool pose. urdfdom rejects
``inf``; the largest float stands for "no limit" both ways.
"""
from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rtctl.errors import ModelError
from rtctl.model.dh import inertial_params
from rtctl.model.robot import MAX_JOINTS, PRISMATIC, REVOLUTE, Model
from rtctl.model.rotations import homogeneous, matrix_rpy, rot_axis, rpy_matrix, skew, trans

_MOVING = {"revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}
_UNLIMITED = sys.float_info.max
_LARGEST = 1e6  # any other number's magnitude (m, rad, kg, kg·m²): past it products overflow


@dataclass
class _Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # 4×4
    axis: np.ndarray
    limits: tuple[float, float, float, float]  # lower, upper, velocity, effort


def load_urdf(path, *, lock: dict[str, float] | None = None, flange_link: str | None = None) -> Model:
    """A Model from a URDF file (see the module docstring for the rules)."""
    path = Path(path)
    try:
        text = path.read_bytes()  # the XML declares its encoding
    except OSError as e:
        raise ModelError(f"{path}: cannot read URDF ({e.strerror or e})") from None
    return parse_urdf(text, lock=lock, flange_link=flange_link, source=str(path))


def parse_urdf(text: str | bytes, *, lock: dict[str, float] | None = None, flange_link: str | None = None,
               source: str = "<urdf>") -> Model:
    """A Model from URDF text. Refused with ModelError: malformed XML or numbers, missing or
    repeated names, a joint loop, links not connected to the root, more than MAX_JOINTS
    moving joints."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        raise ModelError(f"{source}: not valid XML ({e})") from None
    if root.tag != "robot":
        raise ModelError(f"{source}: the root element is <{root.tag}>, expected <robot>")
    lock = dict(lock or {})
    links = {}
    for link in root.findall("link"):
        name = _name(link, source)
        if name in links:
            raise ModelError(f"{source}: two links are named {name!r}")
        links[name] = _in(f"{source}: link {name!r}", _link_params, link, source)
    joints = [_in(f"{source}: joint {j.get('name')!r}", _parse_joint, j, source, lock) for j in root.findall("joint")]
    names = [j.name for j in joints]
    if len(set(names)) != len(names):
        raise ModelError(f"{source}: two joints are named {next(x for x in names if names.count(x) > 1)!r}")
    moving = sum(j.type in _MOVING for j in joints)
    if moving > MAX_JOINTS:
        raise ModelError(f"{source}: {moving} moving joints; rtctl supports robots of at most {MAX_JOINTS}")
    unknown = set(lock) - set(names)
    if unknown:
        raise ModelError(f"{source}: lock names unknown joints {sorted(unknown)}")
    children: dict[str, list[_Joint]] = {name: [] for name in links}
    parent_joint: dict[str, str] = {}
    for j in joints:
        for end in (j.parent, j.child):
            if end not in links:
                raise ModelError(f"{source}: joint {j.name!r} refers to unknown link {end!r}")
        if j.child in parent_joint:  # a second way into a link: a loop (or a graph, not a tree)
            raise ModelError(f"{source}: link {j.child!r} is the child of joints {parent_joint[j.child]!r} and "
                             f"{j.name!r}; a robot is a tree of links (no loops)")
        parent_joint[j.child] = j.name
        children[j.parent].append(j)
    roots = set(links) - set(parent_joint)
    if len(roots) != 1:
        raise ModelError(f"{source}: expected one root link, found {sorted(roots)} "
                         f"{'(every link is a child: the joints form a loop)' if not roots else ''}".rstrip())

    # Depth-first walk: each link gets (body index, placement of the link in that body).
    body_of, placement = {}, {}
    bodies: list[_Joint] = []
    tree: list[np.ndarray] = []
    parents: list[int] = []
    params: list[np.ndarray] = []
    stack = [(roots.pop(), -1, np.eye(4))]
    while stack:
        link, body, T = stack.pop()
        body_of[link], placement[link] = body, T
        if body >= 0:
            params[body] = params[body] + _moved(links[link], T)
        for j in reversed(children[link]):
            if j.type in _MOVING:
                bodies.append(j)
                tree.append(T @ j.origin)
                parents.append(body)
                params.append(np.zeros(10))
                stack.append((j.child, len(bodies) - 1, np.eye(4)))
            else:
                stack.append((j.child, body, T @ j.origin))
    unreachable = set(links) - set(body_of)
    if unreachable:  # one parent each and one root, yet not reached: a loop hanging apart
        raise ModelError(f"{source}: links {sorted(unreachable)} are not connected to the root link "
                         "(their joints form a loop)")
    if not bodies:
        raise ModelError(f"{source}: no revolute, continuous or prismatic joint")
    if parents != list(range(-1, len(bodies) - 1)):
        branch = next(b for b in set(parents) if parents.count(b) > 1)
        names = [j.name for j, b in zip(bodies, parents) if b == branch]
        raise ModelError(f"{source}: joints {names} branch from one body; only serial chains are supported "
                         "(lock the extra joints, e.g. a gripper's fingers)")
    last = len(bodies) - 1
    flange, tool = _end_frames(children, placement, body_of, bodies[-1].child, last, flange_link, source)
    limits = np.array([j.limits for j in bodies])
    return Model(
        name=root.get("name", "robot"),
        joint_names=tuple(j.name for j in bodies),
        joint_types=np.array([_MOVING[j.type] for j in bodies], dtype=np.int64),
        parent=np.array(parents, dtype=np.int64),
        axis=np.array([j.axis for j in bodies]),
        R_tree=np.array([T[:3, :3] for T in tree]),
        p_tree=np.array([T[:3, 3] for T in tree]),
        params=np.array(params),
        q_min=limits[:, 0], q_max=limits[:, 1], v_max=limits[:, 2], tau_max=limits[:, 3],
        flange=flange,
        tool=tool,
    )


def _end_frames(children, placement, body_of, link, last, flange_link, source):
    """Flange and tool placements (see module docstring)."""
    if flange_link is None:
        while len(children[link]) == 1 and children[link][0].child != "tool":
            link = children[link][0].child
        flange_link = link
    if body_of.get(flange_link) != last:
        raise ModelError(f"{source}: flange link {flange_link!r} is not fixed to the last moving body")
    tools = [j for j in children[flange_link] if j.child == "tool"]
    tool = placement[tools[0].child] if tools else placement[flange_link]
    flange = placement[flange_link]
    return flange, np.linalg.solve(flange, tool)


def _name(element, source) -> str:
    name = element.get("name")
    if not name:
        raise ModelError(f"{source}: a <{element.tag}> without a name")
    return name


class _BadNumber(ModelError):
    """A number attribute that is none, without the file and element it is in (``_in`` adds them)."""


def _in(where: str, parse, *args):
    """``parse(*args)``, a bad number in it named with ``where`` (the file, the link or joint)."""
    try:
        return parse(*args)
    except _BadNumber as e:
        raise ModelError(f"{where}: {e}") from None


def _floats(element, attr, count, default):
    text = element.get(attr) if element is not None else None
    if text is None:
        return np.array(default, dtype=float)
    try:
        values = np.array([float(x) for x in text.split()])
    except ValueError:
        values = np.array([np.nan])
    if values.shape != (count,) or not np.all(np.abs(values) <= _LARGEST):
        raise _BadNumber(f"<{element.tag} {attr}={text!r}>: expected {count} numbers of magnitude ≤ {_LARGEST:g}")
    return values


def _float(element, attr, default, *, lo=-np.inf, unlimited=False) -> float:
    """A number attribute: finite and ≥ ``lo`` (±inf too where ``unlimited``: a limit)."""
    text = element.get(attr)
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        value = np.nan
    if np.isnan(value) or (abs(value) > _LARGEST and not unlimited) or value < lo:
        raise _BadNumber(f"<{element.tag} {attr}={text!r}>: expected a number"
                         f"{'' if unlimited else f' of magnitude ≤ {_LARGEST:g}'}{f' ≥ {lo:g}' if lo > -np.inf else ''}")
    return value


def _origin(element) -> np.ndarray:
    origin = element.find("origin")
    return homogeneous(rpy_matrix(_floats(origin, "rpy", 3, (0, 0, 0))), _floats(origin, "xyz", 3, (0, 0, 0)))


def _link_params(link, source) -> np.ndarray:
    """The link's 10 parameters in its own frame (zero without <inertial>)."""
    inertial = link.find("inertial")
    if inertial is None:
        return np.zeros(10)
    mass_el, inertia_el = inertial.find("mass"), inertial.find("inertia")
    if mass_el is None or inertia_el is None:
        raise ModelError(f"{source}: link {link.get('name')!r}: <inertial> needs <mass> and <inertia>")
    if mass_el.get("value") is None:  # (URDF requires it)
        raise ModelError(f"{source}: link {link.get('name')!r}: <mass> needs a value")
    m = _float(mass_el, "value", 0.0, lo=0.0)
    c = {k: _float(inertia_el, k, 0.0) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    Ic = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]], [c["ixz"], c["iyz"], c["izz"]]])
    T = _origin(inertial)
    return inertial_params(m, T[:3, 3], T[:3, :3] @ Ic @ T[:3, :3].T)


def _moved(p, T) -> np.ndarray:
    """Parameters p of a link placed at T in the body, expressed in the body frame."""
    if not np.any(p):
        return p
    m, h = p[0], p[1:4]
    R, r = T[:3, :3], T[:3, 3]
    J = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
    hb = R @ h + m * r
    # J about the body origin: rotate, then shift (book Table 2.8, rigid-body inertia transform)
    rx, hx = skew(r), skew(R @ h)
    Jb = R @ J @ R.T - m * rx @ rx - rx @ hx - hx @ rx
    return np.array([m, *hb, Jb[0, 0], Jb[0, 1], Jb[1, 1], Jb[0, 2], Jb[1, 2], Jb[2, 2]])


def _parse_joint(j, source, lock) -> _Joint:
    name, jtype = _name(j, source), j.get("type")
    parent, child = j.find("parent"), j.find("child")
    if parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise ModelError(f"{source}: joint {name!r} needs <parent link=...> and <child link=...>")
    if jtype not in _MOVING and jtype != "fixed":
        raise ModelError(f"{source}: joint {name!r} has type {jtype!r}; supported: revolute, continuous, "
                         "prismatic, fixed")
    axis = _floats(j.find("axis"), "xyz", 3, (1, 0, 0))
    norm = np.linalg.norm(axis)
    if jtype != "fixed" and norm == 0:
        raise ModelError(f"{source}: joint {name!r} has a zero axis")
    axis = axis / norm if norm else axis
    origin = _origin(j)
    if name in lock:
        if jtype == "fixed":
            raise ModelError(f"{source}: cannot lock fixed joint {name!r}")
        value = float(lock[name])
        if not np.isfinite(value):
            raise ModelError(f"{source}: lock {name!r} at a non-finite position {value}")
        motion = homogeneous(rot_axis(axis, value)) if _MOVING[jtype] == REVOLUTE else trans(*(axis * value))
        origin, jtype = origin @ motion, "fixed"
    elif j.find("mimic") is not None:
        raise ModelError(f"{source}: joint {name!r} mimics another joint; lock it instead")
    limit = j.find("limit")
    lo, hi = (-np.inf, np.inf) if jtype == "continuous" else (_limit(limit, "lower", -np.inf), _limit(limit, "upper", np.inf))
    limits = (lo, hi, _limit(limit, "velocity", np.inf), _limit(limit, "effort", np.inf))
    if not lo < hi or not (limits[2] > 0 and limits[3] > 0):
        raise ModelError(f"{source}: joint {name!r}: limits need lower < upper and velocity, effort > 0, "
                         f"got {limits}")
    return _Joint(name, jtype, parent.get("link"), child.get("link"), origin, axis, limits)


def _limit(limit, attr, default) -> float:
    if limit is None:
        return default
    value = _float(limit, attr, default, unlimited=True)
    return np.copysign(np.inf, value) if abs(value) >= _UNLIMITED else value


def _num(x: float) -> str:
    return repr(float(np.clip(x, -_UNLIMITED, _UNLIMITED)))


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)


def _origin_xml(T) -> str:
    return f'<origin xyz="{_vec(T[:3, 3])}" rpy="{_vec(matrix_rpy(T[:3, :3]))}"/>'


def _inertial_xml(p) -> str:
    m = p[0]
    if m < 0:
        raise ModelError(f"cannot write a negative mass ({m}) to URDF")
    c = p[1:4] / m if m > 0 else np.zeros(3)
    if m == 0 and np.any(p[1:4]):
        raise ModelError("cannot write a first moment without mass to URDF")
    J = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
    Ic = J - m * (c @ c * np.eye(3) - np.outer(c, c))  # back to the centre of mass
    return (f'<inertial><origin xyz="{_vec(c)}" rpy="0 0 0"/><mass value="{_num(m)}"/>'
            f'<inertia ixx="{_num(Ic[0, 0])}" ixy="{_num(Ic[0, 1])}" ixz="{_num(Ic[0, 2])}" '
            f'iyy="{_num(Ic[1, 1])}" iyz="{_num(Ic[1, 2])}" izz="{_num(Ic[2, 2])}"/></inertial>')


def to_urdf(model: Model) -> str:
    """URDF text for ``model`` (see the module docstring for the layout)."""
    def link_name(i):
        return "base_link" if i < 0 else f"link{i + 1}"

    lines = ['<?xml version="1.0"?>', f'<robot name="{model.name}">', '  <link name="base_link"/>']
    for i in range(model.nq):
        revolute = model.joint_types[i] == REVOLUTE
        unlimited = not (np.isfinite(model.q_min[i]) or np.isfinite(model.q_max[i]))
        jtype = ("continuous" if unlimited else "revolute") if revolute else "prismatic"
        bounds = "" if jtype == "continuous" else f'lower="{_num(model.q_min[i])}" upper="{_num(model.q_max[i])}" '
        lines += [
            f'  <link name="{link_name(i)}">{_inertial_xml(model.params[i])}</link>',
            f'  <joint name="{model.joint_names[i]}" type="{jtype}">',
            f'    <parent link="{link_name(model.parent[i])}"/><child link="{link_name(i)}"/>',
            f"    {_origin_xml(homogeneous(model.R_tree[i], model.p_tree[i]))}",
            f'    <axis xyz="{_vec(model.axis[i])}"/>',
            f'    <limit {bounds}velocity="{_num(model.v_max[i])}" effort="{_num(model.tau_max[i])}"/>',
            "  </joint>",
        ]
    for name, parent, T in (("flange", link_name(model.nq - 1), model.flange), ("tool", "flange", model.tool)):
        lines += [
            f'  <link name="{name}"/>',
            f'  <joint name="{name}_joint" type="fixed"><parent link="{parent}"/><child link="{name}"/>'
            f"{_origin_xml(T)}</joint>",
        ]
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
