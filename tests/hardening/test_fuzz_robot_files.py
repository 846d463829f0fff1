"""Fuzzing robot descriptions: the shipped D-H tables with one key or array element mutated,
and the shipped robots written as URDF with one element or attribute mutated — garbage,
non-finite and absurd numbers, deleted or duplicated elements, joints re-pointed to make loops,
names removed or repeated. `rtctl model` (load, then FK, H, G) must exit 0 or 2 within a time
limit, never raise; a non-finite number or a string where a number was is refused naming it."""
from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET

import pytest
import tomli_w
from hypothesis import given, strategies as st

from fuzz_helpers import (FUZZ, MUTATIONS, NON_FINITE, acceptable_names, get, is_number, key_name, leaves, mutate,
                          rtctl_in_process)
from runtime_helpers import ROOT
from rtctl.model import load_robot

ROBOTS = sorted((ROOT / "configs" / "robots").glob("*.toml"))


@pytest.mark.parametrize("robot", ROBOTS, ids=lambda p: p.stem)
def test_fuzz_dh_tables(robot, tmp_path):
    doc = tomllib.loads(robot.read_text())
    paths = list(leaves(doc))

    @FUZZ
    @given(path=st.sampled_from(paths), how=st.sampled_from(MUTATIONS + ("duplicate joint",)))
    def case(path, how):
        if how == "duplicate joint":
            mutant = {**doc, "joints": doc["joints"] + doc["joints"][-1:]}
        else:
            mutant = mutate(doc, path, how)
        target = tmp_path / "fuzz.toml"
        target.write_text(tomli_w.dumps(mutant))
        code, _, err = rtctl_in_process("model", target)
        assert code in (0, 2), (key_name(path), how, code, err)
        if how == "duplicate joint":
            assert code == 2 and "used once" in err, err
        elif how in NON_FINITE and is_number(get(doc, path)):
            assert code == 2 and key_name(path) in err, (key_name(path), how, err)
        elif how == "string" and is_number(get(doc, path)):
            assert code == 2 and any(k in err for k in acceptable_names(path)), (key_name(path), how, err)

    case()


GARBAGE = ("a b c", "nan", "inf", "-inf", "-1", "0", "1e400", "1e300 1e300 1e300", "", "1 2")


def _urdf_mutations(root: ET.Element):
    """(description, mutate(tree)) pairs: every attribute, element and link reference."""
    elements = list(root.iter())
    links = [e.get("name") for e in root.findall("link")]
    out = []
    for i, el in enumerate(elements):
        for attr in el.attrib:
            out += [(f"{el.tag}[{i}].{attr}={g!r}", (i, "set", attr, g)) for g in GARBAGE]
            out.append((f"{el.tag}[{i}] without {attr}", (i, "drop", attr, None)))
        if el is not root:
            out += [(f"{el.tag}[{i}] deleted", (i, "delete", None, None)),
                    (f"{el.tag}[{i}] twice", (i, "duplicate", None, None))]
        if el.tag in ("parent", "child"):
            out += [(f"{el.tag}[{i}] → {link}", (i, "set", "link", link)) for link in links]
    return out


def _apply(root: ET.Element, action) -> str:
    root = ET.fromstring(ET.tostring(root))
    i, what, attr, value = action
    elements = list(root.iter())
    el = elements[i]
    parent = next(p for p in root.iter() if el in list(p)) if el is not root else None
    if what == "set":
        el.set(attr, value)
    elif what == "drop":
        del el.attrib[attr]
    elif what == "delete":
        parent.remove(el)
    else:
        parent.append(ET.fromstring(ET.tostring(el)))
    return ET.tostring(root, encoding="unicode")


@pytest.mark.parametrize("robot", ["puma560", "table1_arm"])
def test_fuzz_urdf(robot, tmp_path):
    root = ET.fromstring(load_robot(ROOT / "configs" / "robots" / f"{robot}.toml").to_urdf())
    mutations = _urdf_mutations(root)

    @FUZZ
    @given(st.sampled_from(mutations))
    def case(mutation):
        name, action = mutation
        target = tmp_path / "fuzz.urdf"
        target.write_text(_apply(root, action))
        code, _, err = rtctl_in_process("model", target)
        assert code in (0, 2), (name, code, err)
        if code == 2:
            assert str(target) in err or "<" in err, (name, err)  # names the file or the element

    case()


def test_rtctl_model_checks_the_robot_files_interference_zones(tmp_path):
    """Found by the fuzzer: a zone's coordinate given as a string passed `rtctl model` (the
    zones were read only by a run)."""
    doc = tomllib.loads((ROOT / "configs" / "robots" / "puma560.toml").read_text())
    doc["guard"]["zones"][0]["polygon"][0][0] = ""
    target = tmp_path / "robot.toml"
    target.write_text(tomli_w.dumps(doc))
    code, out, err = rtctl_in_process("model", target)
    assert code == 2 and "guard.zones[0].polygon" in err, err
    code, out, err = rtctl_in_process("model", ROOT / "configs" / "robots" / "puma560.toml")
    assert code == 0 and "wrist_vs_floor_front" in out, err
