"""Defect 11: two devices sharing one CAN bus must not use the same CAN id (check used to pass
it while printing that the bus was shared; hil-sim refused it)."""
from __future__ import annotations

import json

import pytest

from rtctl.cli import main
from runtime_helpers import ROOT

JOINTS = ["waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange"]


def shared_bus(first: str, second: str) -> str:
    text = f'[robot]\ndescription = "{ROOT}/configs/robots/puma560.toml"\n[loop]\nrate_hz = 500.0\n'
    for k, (names, extra) in enumerate(((JOINTS[:3], first), (JOINTS[3:], second))):
        text += (f'[[devices]]\nname = "d{k}"\ndriver = "mit_can"\njoints = {json.dumps(names)}\n{extra}\n'
                 '[devices.bus]\ninterface = "socketcan"\nchannel = "can0"\nbitrate = 1000000\n')
    return text


@pytest.mark.parametrize("first, second, key, words", [
    ("", "", "devices[1].ids", "0x1 (joint wrist_roll) is also drive 0x1 of d0"),  # both default to ids 1, 2, 3
    ("ids = [1, 2, 3]", "ids = [4, 5, 3]", "devices[1].ids", "0x3"),
    ("ids = [1, 2, 3]", "ids = [4, 5, 6]\nmaster_id = 2", "devices[1].master_id", "0x2"),
])
def test_defect_11_the_same_can_id_on_one_bus_exits_2(write_config, capsys, first, second, key, words):
    assert main(["check", str(write_config(shared_bus(first, second)))]) == 2
    err = capsys.readouterr().err
    assert key in err and words in err, err


def test_defect_11_distinct_ids_on_one_bus_pass(write_config, capsys):
    assert main(["check", str(write_config(shared_bus("ids = [1, 2, 3]", "ids = [4, 5, 6]")))]) == 0
    assert "shared by devices d0, d1" in capsys.readouterr().out
