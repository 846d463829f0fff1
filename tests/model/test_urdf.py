"""URDF reading and writing: round trips, and our reading of real URDFs against Pinocchio's."""
from dataclasses import replace

import numpy as np
import pytest

from rtctl.errors import ModelError
from rtctl.model import PRISMATIC, REVOLUTE
from rtctl.model.kinematics import link_poses
from rtctl.model.rotations import rot_axis
from rtctl.model.urdf import load_urdf, parse_urdf

FIELDS = ("axis", "R_tree", "p_tree", "params", "q_min", "q_max", "v_max", "tau_max", "flange", "tool", "gravity")


def assert_same_model(a, b, tol=1e-12):
    assert a.joint_names == b.joint_names
    np.testing.assert_array_equal(a.joint_types, b.joint_types)
    np.testing.assert_array_equal(a.parent, b.parent)
    for name in FIELDS:
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), atol=tol, err_msg=name)


@pytest.mark.parametrize("robot", ["puma", "two_link", "ur5", "panda"])
def test_round_trip_of_shipped_and_real_robots(robot, request):
    model = request.getfixturevalue(robot)
    assert_same_model(parse_urdf(model.to_urdf()), model)


@pytest.mark.parametrize("seed", range(5))
def test_round_trip_of_random_chains_with_unlimited_joints(seed, random_chain):
    model = random_chain(7, seed)
    inf = np.full(model.nq, np.inf)
    model = replace(model, q_min=-inf, q_max=inf, v_max=inf, tau_max=inf)
    assert PRISMATIC in model.joint_types and REVOLUTE in model.joint_types
    back = parse_urdf(model.to_urdf())
    assert_same_model(back, model)
    assert np.all(np.isinf(back.q_max)) and np.all(np.isinf(back.tau_max))


def test_tool_frame_is_pinocchio_frame_tool(random_chain, pin, pin_twin, pin_q):
    model = random_chain(6, 11)
    pmodel, pdata = pin_twin(model)
    q = np.linspace(-1, 1, model.nq)
    pin.framesForwardKinematics(pmodel, pdata, pin_q(pmodel, q))
    # our forward kinematics by hand: body placements compose T_tree · T_joint(q)
    T = np.eye(4)
    for i in range(model.nq):
        J = np.eye(4)
        if model.joint_types[i] == REVOLUTE:
            J[:3, :3] = rot_axis(model.axis[i], q[i])
        else:
            J[:3, 3] = model.axis[i] * q[i]
        tree = np.eye(4)
        tree[:3, :3], tree[:3, 3] = model.R_tree[i], model.p_tree[i]
        T = T @ tree @ J
    expected = T @ model.flange @ model.tool
    np.testing.assert_allclose(pdata.oMf[pmodel.getFrameId("tool", pin.BODY)].homogeneous, expected, atol=1e-12)


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_reading_matches_pinocchio(robot, request):
    model = request.getfixturevalue(robot)
    pmodel, _ = request.getfixturevalue(f"pin_{robot}")
    assert pmodel.nv == model.nq
    assert tuple(pmodel.names)[1:] == model.joint_names
    for i in range(model.nq):
        placement = pmodel.jointPlacements[i + 1]
        np.testing.assert_allclose(model.R_tree[i], placement.rotation, atol=1e-12)
        np.testing.assert_allclose(model.p_tree[i], placement.translation, atol=1e-12)
        np.testing.assert_allclose(model.params[i], pmodel.inertias[i + 1].toDynamicParameters(), atol=1e-12)
    np.testing.assert_allclose(model.q_min, pmodel.lowerPositionLimit)
    np.testing.assert_allclose(model.q_max, pmodel.upperPositionLimit)
    np.testing.assert_allclose(model.v_max, pmodel.velocityLimit)
    np.testing.assert_allclose(model.tau_max, pmodel.effortLimit)


def _urdf(joints, links=("base", "a", "b")):
    body = "".join(f'<link name="{n}"/>' for n in links)
    return f'<robot name="t">{body}{joints}</robot>'


def _one_heavy_link(mass, ixx):
    inertial = f'<inertial><mass value="{mass}"/><inertia ixx="{ixx}" iyy="1" izz="1"/></inertial>'
    return f'<robot name="t"><link name="base"/><link name="a">{inertial}</link>{joint("j", "base", "a")}</robot>'


REV = '<joint name="{n}" type="{t}"><parent link="{p}"/><child link="{c}"/><axis xyz="{ax}"/>{extra}</joint>'


def joint(n, p, c, t="revolute", ax="0 0 1", extra='<limit lower="-1" upper="1" effort="1" velocity="1"/>'):
    return REV.format(n=n, t=t, p=p, c=c, ax=ax, extra=extra)


@pytest.mark.parametrize("text, message", [
    ("<robot", "not valid XML"),
    ("<model/>", "expected <robot>"),
    (_urdf(joint("j", "base", "a", t="fixed"), links=("base", "a")), "no revolute"),
    (_urdf(joint("j", "base", "a", t="floating")), "supported"),
    (_urdf(joint("j", "base", "a", ax="0 0 0")), "zero axis"),
    (_urdf(joint("j", "base", "zz")), "unknown link"),
    (_urdf(joint("j", "base", "a") + joint("k", "base", "b")), "serial chains"),
    (_urdf(joint("j", "base", "a") + joint("k", "a", "b", extra='<mimic joint="j"/>')), "lock it"),
    (_urdf(joint("j", "base", "a"), links=("base", "a", "b")), "one root"),
    (_urdf(joint("j", "base", "a") + joint("j", "a", "b")), "two joints are named 'j'"),
    (_urdf(joint("j", "base", "a", extra='<limit lower="-1" upper="1" effort="0" velocity="1"/>'),
           links=("base", "a")), "effort > 0"),
    (_one_heavy_link(mass="-1", ixx="1"), "value='-1'.* ≥ 0"),
    (_one_heavy_link(mass="1", ixx="1e300"), "magnitude ≤"),
])
def test_malformed_urdf_is_refused_with_a_reason(text, message):
    with pytest.raises(ModelError, match=message):
        parse_urdf(text)


def test_an_unreadable_file_is_refused_saying_why_once(tmp_path):
    missing = tmp_path / "arm.urdf"
    with pytest.raises(ModelError) as e:
        load_urdf(missing)
    assert str(e.value) == f"{missing}: cannot read URDF (No such file or directory)"


def test_lock_and_unknown_lock():
    text = _urdf(joint("j", "base", "a") + joint("k", "a", "b", t="prismatic", ax="1 0 0"))
    model = parse_urdf(text, lock={"k": 0.25})
    assert model.joint_names == ("j",)
    np.testing.assert_allclose(model.flange[:3, 3], [0.25, 0, 0])
    with pytest.raises(ModelError, match="unknown joints"):
        parse_urdf(text, lock={"nope": 0.0})
    with pytest.raises(ModelError, match="cannot read"):
        load_urdf("/nonexistent.urdf")


def test_fixed_links_merge_their_inertia_into_the_body():
    # two point-like masses on fixed joints sum to the parameters of the pair, about the body origin
    link = '<link name="{n}"><inertial><origin xyz="{c}"/><mass value="{m}"/><inertia ixx="0" iyy="0" izz="0"/></inertial></link>'
    text = ('<robot name="t"><link name="base"/><link name="a"/>' + link.format(n="m1", c="0 0 0", m=2)
            + link.format(n="m2", c="0 0 0", m=3) + joint("j", "base", "a")
            + '<joint name="f1" type="fixed"><parent link="a"/><child link="m1"/><origin xyz="1 0 0" rpy="0 0 1.0"/></joint>'
            + '<joint name="f2" type="fixed"><parent link="a"/><child link="m2"/><origin xyz="0 2 0"/></joint></robot>')
    p = parse_urdf(text).params[0]
    np.testing.assert_allclose(p[:4], [5, 2, 6, 0])
    # J about the origin of point masses: Σ m (|r|² 1 − r rᵀ)
    np.testing.assert_allclose(p[4:], [3 * 4, 0, 2 * 1, 0, 0, 2 * 1 + 3 * 4])


def _chain_with_axes(axes, seed):
    """A serial chain whose joint k has axis ``axes[k]`` (None: no <axis> element), with
    arbitrary placements, read by both parsers from the same text."""
    rng = np.random.default_rng(seed)
    links = ["base"] + [f"l{k}" for k in range(len(axes))]
    inertia = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
               '</inertial>')
    body = '<link name="base"/>' + "".join(f'<link name="{n}">{inertia}</link>' for n in links[1:])
    joints = ""
    for k, ax in enumerate(axes):
        xyz, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-1, 1, 3)
        axis = "" if ax is None else f'<axis xyz="{" ".join(map(str, ax))}"/>'
        joints += (f'<joint name="j{k}" type="revolute"><parent link="{links[k]}"/><child link="{links[k + 1]}"/>'
                   f'<origin xyz="{" ".join(map(str, xyz))}" rpy="{" ".join(map(str, rpy))}"/>{axis}'
                   '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>')
    return f'<robot name="axes">{body}{joints}</robot>'


@pytest.mark.parametrize("seed", range(3))
def test_axes_are_read_as_pinocchio_reads_them_unnormalised_or_absent(seed, pin):
    """URDF's axis is a direction: "0 0 2" turns about z by q (not 2q); no <axis> means x."""
    rng = np.random.default_rng(100 + seed)
    axes = [None, (0, 0, 2), (0.5, 0, 0), tuple(rng.uniform(-3, 3, 3)), None, (0, -4, 0)]
    text = _chain_with_axes(axes, seed)
    model = parse_urdf(text)
    pmodel = pin.buildModelFromXML(text)
    pdata = pmodel.createData()
    np.testing.assert_allclose(np.linalg.norm(model.axis, axis=1), 1.0, atol=1e-15)
    for _ in range(5):
        q = rng.uniform(-2, 2, len(axes))
        pin.forwardKinematics(pmodel, pdata, q)
        poses = link_poses(model, q)
        for k in range(len(axes)):
            np.testing.assert_allclose(poses[k], pdata.oMi[k + 1].homogeneous, atol=1e-12)


def _full_inertia(rng):
    """A physically valid inertia tensor with products of inertia (a rotated diagonal one)."""
    principal = rng.uniform(0.05, 0.3, 3)
    principal[2] = min(principal[2], principal[0] + principal[1] - 1e-3)  # triangle inequality
    R = rot_axis(rng.normal(size=3) / 2, rng.uniform(0, 3))
    J = R @ np.diag(principal) @ R.T
    J = J.tolist()
    return (f'<inertia ixx="{J[0][0]!r}" ixy="{J[0][1]!r}" ixz="{J[0][2]!r}" iyy="{J[1][1]!r}" '
            f'iyz="{J[1][2]!r}" izz="{J[2][2]!r}"/>')


@pytest.mark.parametrize("seed", range(3))
def test_full_inertia_tensors_read_merged_and_written_as_pinocchio_reads_them(seed, pin):
    """Products of inertia on the moving links and on rotated, offset fixed links merged into
    them: every body's 10 parameters as Pinocchio has them, read from our URDF and from the one
    to_urdf writes."""
    rng = np.random.default_rng(200 + seed)
    vec = lambda v: " ".join(repr(float(x)) for x in v)  # noqa: E731
    links, joints = ['<link name="base"/>'], ""
    for k in range(3):
        for name in (f"l{k}", f"l{k}_tool"):
            links.append(f'<link name="{name}"><inertial><origin xyz="{vec(rng.uniform(-0.2, 0.2, 3))}" '
                         f'rpy="{vec(rng.uniform(-1, 1, 3))}"/><mass value="{float(rng.uniform(0.5, 3))!r}"/>'
                         f'{_full_inertia(rng)}</inertial></link>')
        joints += (f'<joint name="j{k}" type="revolute"><parent link="{"base" if k == 0 else f"l{k - 1}"}"/>'
                   f'<child link="l{k}"/><origin xyz="{vec(rng.uniform(-0.3, 0.3, 3))}" rpy="{vec(rng.uniform(-1, 1, 3))}"/>'
                   f'<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
                   f'<joint name="f{k}" type="fixed"><parent link="l{k}"/><child link="l{k}_tool"/>'
                   f'<origin xyz="{vec(rng.uniform(-0.3, 0.3, 3))}" rpy="{vec(rng.uniform(-1, 1, 3))}"/></joint>')
    text = f'<robot name="full">{"".join(links)}{joints}</robot>'
    model = parse_urdf(text)
    for source in (text, model.to_urdf()):
        pmodel = pin.buildModelFromXML(source)
        for i in range(3):
            np.testing.assert_allclose(model.params[i], pmodel.inertias[i + 1].toDynamicParameters(), atol=1e-10)
