"""Defects 8, 9, 13 (robot files), 14 and 15: robot descriptions that are malformed, looped,
too large or ambiguous exit 2 with a clear message; optional keys are optional."""
from __future__ import annotations

import pytest

from runtime_helpers import BASE, ROOT
from rtctl.cli import main
from rtctl.errors import ModelError
from rtctl.model import load_robot
from rtctl.model.urdf import parse_urdf

TWO_LINK = (ROOT / "configs" / "robots" / "two_link.toml").read_text()

URDF = """<robot name="r">
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0 0 0.1"/><mass value="{mass}"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <origin xyz="{xyz}"/><axis xyz="0 0 1"/><limit lower="{lower}" upper="1" velocity="1" effort="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  {extra}
</robot>"""


def urdf(mass="1.0", xyz="0 0 0.5", lower="-1", extra=""):
    return URDF.format(mass=mass, xyz=xyz, lower=lower, extra=extra)


def _check(tmp_path, capsys, text, suffix, *words):
    path = tmp_path / f"robot{suffix}"
    path.write_text(text)
    code = main(["model", str(path)])
    err = capsys.readouterr().err
    assert code == 2, err
    for w in words:
        assert w in err, (w, err)


def test_urdf_fixture_is_valid():
    assert parse_urdf(urdf()).nq == 2


@pytest.mark.timeout(30)
def test_defect_08_urdf_joint_loop_exits_2(tmp_path, capsys):
    # b → a closes the loop base → a → b → a (the old walk never ended, growing past 1.4 GB)
    loop = urdf(extra='<joint name="j3" type="revolute"><parent link="b"/><child link="a"/>'
                      '<axis xyz="1 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>')
    _check(tmp_path, capsys, loop, ".urdf", "loop")
    # a loop apart from the root: every link of it has one parent, yet the root never reaches it
    apart = urdf(extra='<link name="c"/><link name="d"/>'
                       '<joint name="j3" type="fixed"><parent link="c"/><child link="d"/></joint>'
                       '<joint name="j4" type="fixed"><parent link="d"/><child link="c"/></joint>')
    _check(tmp_path, capsys, apart, ".urdf", "loop")


def test_defect_09_dh_file_without_gravity_loads_with_the_default(tmp_path):
    path = tmp_path / "no_gravity.toml"
    path.write_text("\n".join(line for line in TWO_LINK.splitlines() if not line.startswith("gravity")))
    model = load_robot(path)
    assert model.gravity.tolist() == [0.0, 0.0, -9.81]
    assert main(["model", str(path)]) == 0


@pytest.mark.parametrize("text, words", [
    (urdf(xyz="a b c"), ["xyz", "3 numbers"]),
    (urdf(lower="abc"), ["lower", "number"]),
    (urdf(mass="heavy"), ["value", "number"]),
])
def test_defect_13_non_numeric_urdf_attributes_exit_2(tmp_path, capsys, text, words):
    _check(tmp_path, capsys, text, ".urdf", *words)


@pytest.mark.parametrize("suffix", [".urdf", ".toml"])
def test_defect_13_description_path_that_is_a_directory_exits_2(write_config, tmp_path, capsys, suffix):
    (tmp_path / f"robot{suffix}").mkdir()
    config = write_config(BASE.replace(f'description = "{ROOT}/configs/robots/puma560.toml"',
                                       f'description = "{tmp_path}/robot{suffix}"'))
    assert main(["check", str(config)]) == 2
    assert f"robot{suffix}" in capsys.readouterr().err


def test_defect_13_urdf_not_utf8_exits_2(tmp_path, capsys):
    path = tmp_path / "latin1.urdf"
    path.write_bytes(urdf().replace('name="r"', 'name="caf\xe9"').encode("latin-1"))
    assert main(["model", str(path)]) == 2
    assert "not valid XML" in capsys.readouterr().err


MAX_JOINTS = 64  # the supported robot size (rtctl.model.robot.MAX_JOINTS)


def test_defect_14_more_joints_than_supported_exit_2(tmp_path, capsys):
    from rtctl.model.robot import MAX_JOINTS as supported

    assert supported == MAX_JOINTS
    joint = '\n[[joints]]\nname = "j{k}"\nalpha = 0\na = 0.1\nd = 0\n'
    head = 'name = "snake"\nangle_unit = "rad"\n'
    big = head + "".join(joint.format(k=k) for k in range(MAX_JOINTS + 1))
    _check(tmp_path, capsys, big, ".toml", "joints", f"1 to {MAX_JOINTS}")
    ok = head + "".join(joint.format(k=k) for k in range(MAX_JOINTS))
    (tmp_path / "ok.toml").write_text(ok)
    assert load_robot(tmp_path / "ok.toml").nq == MAX_JOINTS
    links = "".join(f'<link name="l{k}"/>' for k in range(MAX_JOINTS + 2))
    joints = "".join(f'<joint name="j{k}" type="continuous"><parent link="l{k}"/><child link="l{k + 1}"/></joint>'
                     for k in range(MAX_JOINTS + 1))
    with pytest.raises(ModelError, match=f"at most {MAX_JOINTS}"):
        parse_urdf(f'<robot name="snake">{links}{joints}</robot>')


@pytest.mark.parametrize("text, words", [
    (urdf(mass="nan"), ["value", "number"]),
    (urdf(mass="-1"), ["value", "≥ 0"]),
    (urdf().replace('<link name="b"/>', '<link name="b"/><link name="b"/>'), ["two links", "'b'"]),
    (urdf().replace('<joint name="j2"', '<joint'), ["without a name"]),
    (urdf().replace('<joint name="j2"', '<joint name="j1"'), ["two joints", "'j1'"]),
])
def test_defect_15_ambiguous_or_impossible_urdf_is_refused(tmp_path, capsys, text, words):
    _check(tmp_path, capsys, text, ".urdf", *words)


def test_defect_15_duplicate_dh_joint_names_are_refused(tmp_path, capsys):
    text = TWO_LINK.replace('name = "joint2"', 'name = "joint1"')
    assert text != TWO_LINK
    _check(tmp_path, capsys, text, ".toml", "joints[1].name", "used once")
