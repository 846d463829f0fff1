"""URDF reading and writing, the cases a full mutation run of rtctl/model/urdf.py found
unchecked (docs/mutation/urdf.md):

* numbers of magnitude up to 10⁶ are taken, one more is refused — in a vector and a number;
* a refusal names what is wrong: the duplicated joint (not the first joint), the joints that
  branch, a loop where every link is a child, a number that is no number (never a bare
  ``ValueError``), the count a vector needs, no "≥ -inf" where no lower bound applies;
* exactly MAX_JOINTS moving joints are taken;
* an ``<origin>`` without ``rpy`` has no rotation (checked by Pinocchio's reader too);
* ``<inertial>`` needs ``<mass>`` and ``<inertia>``, and ``<mass>`` its value (URDF requires it;
  a missing one used to read as 0);
* a joint needs ``<parent link>`` and ``<child link>``; lower < upper, velocity > 0, effort > 0;
* writing: a negative mass or a first moment without mass is refused, a massless link with a
  rotational inertia is written, one finite limit and one unlimited are both kept, and the
  links are named ``base_link``, ``link1`` … ``linkN`` (the module docstring).
"""
from dataclasses import replace

import numpy as np
import pytest

from rtctl.errors import ModelError
from rtctl.model.robot import MAX_JOINTS
from rtctl.model.urdf import parse_urdf

LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


def _joint(n, p, c, extra=LIMIT, origin="", t="revolute"):
    return (f'<joint name="{n}" type="{t}"><parent link="{p}"/><child link="{c}"/>{origin}'
            f'<axis xyz="0 0 1"/>{extra}</joint>')


def _chain(n, origin="", inertial=""):
    links = "".join(f'<link name="l{i}">{inertial if i else ""}</link>' for i in range(n + 1))
    joints = "".join(_joint(f"j{i}", f"l{i}", f"l{i + 1}", origin=origin) for i in range(n))
    return f'<robot name="t">{links}{joints}</robot>'


@pytest.mark.parametrize("x, taken", [("1000000", True), ("-1000000", True), ("1000000.5", False)])
def test_a_vector_takes_magnitudes_up_to_a_million(x, taken):
    text = _chain(1, origin=f'<origin xyz="{x} 0 0"/>')
    if taken:
        assert parse_urdf(text).p_tree[0, 0] == float(x)
    else:
        with pytest.raises(ModelError, match=r"expected 3 numbers of magnitude ≤ 1e\+06"):
            parse_urdf(text)


@pytest.mark.parametrize("mass, taken", [("1000000", True), ("1000000.5", False)])
def test_a_number_takes_magnitudes_up_to_a_million(mass, taken):
    text = _chain(1, inertial=f'<inertial><mass value="{mass}"/><inertia ixx="1" iyy="1" izz="1"/></inertial>')
    if taken:
        assert parse_urdf(text).params[0, 0] == float(mass)
    else:
        with pytest.raises(ModelError, match=r"magnitude ≤ 1e\+06"):
            parse_urdf(text)


@pytest.mark.parametrize("text, message", [
    ('<origin xyz="a b c"/>', r"<origin xyz='a b c'>: expected 3 numbers"),
    ('<origin xyz="1 2"/>', r"<origin xyz='1 2'>: expected 3 numbers"),
    ('<origin rpy="0 0 0 0"/>', r"<origin rpy='0 0 0 0'>: expected 3 numbers"),
])
def test_a_vector_that_is_not_three_numbers_is_refused_by_name(text, message):
    with pytest.raises(ModelError, match=message):
        parse_urdf(_chain(1, origin=text))


def test_a_number_that_is_no_number_is_refused_without_a_lower_bound_in_the_message():
    text = _chain(1, inertial='<inertial><mass value="1"/><inertia ixx="heavy" iyy="1" izz="1"/></inertial>')
    with pytest.raises(ModelError) as e:
        parse_urdf(text)
    assert str(e.value) == "<urdf>: link 'l1': <inertia ixx='heavy'>: expected a number of magnitude ≤ 1e+06"


def test_a_duplicated_joint_name_is_the_one_named():
    links = "".join(f'<link name="l{i}"/>' for i in range(4))
    joints = _joint("first", "l0", "l1") + _joint("twice", "l1", "l2") + _joint("twice", "l2", "l3")
    with pytest.raises(ModelError, match="two joints are named 'twice'"):
        parse_urdf(f'<robot name="t">{links}{joints}</robot>')


def test_the_joints_that_branch_are_the_ones_named():
    """Bodies 0 and 1 in a row, then two joints on body 1: those two are named."""
    links = "".join(f'<link name="{n}"/>' for n in ("base", "upper", "fore", "left", "right"))
    joints = (_joint("shoulder", "base", "upper") + _joint("elbow", "upper", "fore")
              + _joint("lf", "fore", "left") + _joint("rf", "fore", "right"))
    with pytest.raises(ModelError, match=r"joints \[('lf', 'rf'|'rf', 'lf')\] branch from one body"):
        parse_urdf(f'<robot name="t">{links}{joints}</robot>')


def test_a_loop_through_every_link_says_so():
    links = '<link name="a"/><link name="b"/>'
    joints = _joint("ab", "a", "b") + _joint("ba", "b", "a")
    with pytest.raises(ModelError, match=r"expected one root link, found \[\] \(every link is a child"):
        parse_urdf(f'<robot name="t">{links}{joints}</robot>')


def test_exactly_max_joints_moving_joints_are_taken():
    assert parse_urdf(_chain(MAX_JOINTS)).nq == MAX_JOINTS
    with pytest.raises(ModelError, match=f"{MAX_JOINTS + 1} moving joints"):
        parse_urdf(_chain(MAX_JOINTS + 1))


def test_an_origin_without_rpy_has_no_rotation(pin):
    text = _chain(2, origin='<origin xyz="0.1 0.2 0.3"/>')
    model = parse_urdf(text)
    np.testing.assert_array_equal(model.R_tree, np.broadcast_to(np.eye(3), (2, 3, 3)))
    pmodel = pin.buildModelFromXML(text)
    np.testing.assert_allclose(pmodel.jointPlacements[2].rotation, np.eye(3))


@pytest.mark.parametrize("inertial, message", [
    ('<inertial><mass value="1"/></inertial>', "<inertial> needs <mass> and <inertia>"),
    ('<inertial><inertia ixx="1" iyy="1" izz="1"/></inertial>', "<inertial> needs <mass> and <inertia>"),
    ('<inertial><mass/><inertia ixx="1" iyy="1" izz="1"/></inertial>', "link 'l1': <mass> needs a value"),
])
def test_an_inertial_needs_a_mass_with_a_value_and_an_inertia(inertial, message):
    with pytest.raises(ModelError, match=message):
        parse_urdf(_chain(1, inertial=inertial))


@pytest.mark.parametrize("ends", ['<child link="l1"/>', '<parent link="l0"/>',
                                  '<parent/><child link="l1"/>', '<parent link="l0"/><child/>'])
def test_a_joint_needs_a_parent_link_and_a_child_link(ends):
    text = (f'<robot name="t"><link name="l0"/><link name="l1"/><joint name="j" type="revolute">{ends}'
            f'{LIMIT}</joint></robot>')
    with pytest.raises(ModelError, match=r"joint 'j' needs <parent link=...> and <child link=...>"):
        parse_urdf(text)


@pytest.mark.parametrize("limit", ['<limit lower="1" upper="1" effort="1" velocity="1"/>',
                                   '<limit lower="-1" upper="1" effort="1" velocity="0"/>',
                                   '<limit lower="-1" upper="1" effort="1" velocity="-0.5"/>',
                                   '<limit lower="-1" upper="1" effort="0" velocity="1"/>'])
def test_limits_need_lower_below_upper_and_positive_rates(limit):
    text = f'<robot name="t"><link name="l0"/><link name="l1"/>{_joint("j", "l0", "l1", extra=limit)}</robot>'
    with pytest.raises(ModelError, match="limits need lower < upper and velocity, effort > 0"):
        parse_urdf(text)


def _one_body(params, q_min=-1.0, q_max=1.0):
    model = parse_urdf(_chain(1))
    return replace(model, params=np.array([params], dtype=float), q_min=np.array([q_min]), q_max=np.array([q_max]))


@pytest.mark.parametrize("params, message", [
    ([-0.5, 0, 0, 0, 1, 0, 1, 0, 0, 1], "negative mass"),
    ([0.0, 0.1, 0, 0, 0, 0, 0, 0, 0, 0], "first moment without mass"),
    ([0.0, 0, 0, 0.1, 0, 0, 0, 0, 0, 0], "first moment without mass"),
])
def test_writing_refuses_a_negative_mass_or_a_moment_without_mass(params, message):
    with pytest.raises(ModelError, match=message):
        _one_body(params).to_urdf()


def test_writing_a_massless_link_with_a_rotational_inertia_keeps_it():
    params = [0.0, 0, 0, 0, 0.2, 0, 0.3, 0, 0, 0.4]  # m, h, Ixx, Ixy, Iyy, Ixz, Iyz, Izz
    np.testing.assert_allclose(parse_urdf(_one_body(params).to_urdf()).params[0], params)


@pytest.mark.parametrize("q_min, q_max", [(-1.0, np.inf), (-np.inf, 2.0), (-np.inf, np.inf), (-1.0, 2.0)])
def test_writing_keeps_one_finite_limit_beside_an_unlimited_one(q_min, q_max):
    back = parse_urdf(_one_body([1, 0, 0, 0, 1, 0, 1, 0, 0, 1], q_min, q_max).to_urdf())
    assert (back.q_min[0], back.q_max[0]) == (q_min, q_max)


def test_written_links_are_base_link_then_link1_to_linkN():
    import xml.etree.ElementTree as ET

    root = ET.fromstring(parse_urdf(_chain(3)).to_urdf())
    assert [link.get("name") for link in root.findall("link")] == ["base_link", "link1", "link2", "link3",
                                                                    "flange", "tool"]


def test_a_bad_number_names_the_file_and_the_joint(tmp_path):
    from rtctl.model.urdf import load_urdf

    links = "".join(f'<link name="l{i}"/>' for i in range(3))
    joints = _joint("j0", "l0", "l1") + _joint("j1", "l1", "l2", extra=LIMIT.replace('upper="1"', 'upper="x"'))
    path = tmp_path / "arm.urdf"
    path.write_text(f'<robot name="t">{links}{joints}</robot>')
    with pytest.raises(ModelError) as e:
        load_urdf(path)
    assert str(e.value) == f"{path}: joint 'j1': <limit upper='x'>: expected a number"
