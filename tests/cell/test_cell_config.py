"""The cell file: the shipped one loads, the network defaults are the safe ones whatever the
file leaves out, and every mistake exits 2 naming the file, the key path and what was expected."""
from __future__ import annotations

import json
import math
import re

import pytest

from cell_helpers import REPO, write_cell
from rtctl.cell.config import load_cell
from rtctl.cli import main
from rtctl.errors import ConfigError

SHIPPED = REPO / "configs" / "cell" / "two_puma_sim.toml"


def test_the_shipped_cell_loads_with_loopback_peers_and_scouting_off():
    cell = load_cell(SHIPPED)
    assert [r.name for r in cell.robots] == ["left", "right"]
    assert cell.zenoh.host == "127.0.0.1" and not cell.zenoh.multicast_scouting and cell.zenoh.connect == ()
    assert [r.endpoint() for r in cell.robots] == ["tcp/127.0.0.1:7471", "tcp/127.0.0.1:7472"]
    assert cell.state_rate_hz == 100.0
    assert cell.auth.password() == "two-puma-sim-only"
    assert [z.name for z in cell.zones] == ["fixture"] and [g.robot for g in cell.zones[0].regions] == ["left", "right"]
    assert cell.zones[0].regions[0].part.hi.tolist() == [0.8, 0.9]
    assert cell.key("left", "state") == "rtctl/two_puma_sim/left/state"


def test_defaults_when_the_file_says_nothing_about_the_network(tmp_path):
    cell = load_cell(write_cell(tmp_path, 1))  # (no [zenoh] table)
    assert cell.zenoh.host == "127.0.0.1" and not cell.zenoh.multicast_scouting
    assert cell.state_rate_hz == 100.0 and cell.run_dir == tmp_path / "run"


def test_the_zenoh_configuration_written_is_peer_loopback_without_multicast(tmp_path):
    pytest.importorskip("zenoh", reason="the `cell` extra (eclipse-zenoh) is not installed")
    from rtctl.cell.session import session_config

    cell = load_cell(write_cell(tmp_path, 1))
    c = session_config(cell, listen=(cell.robots[0].endpoint(),), user="u", password="p", verify=True)
    assert json.loads(c.get_json("mode")) == "peer"
    assert json.loads(c.get_json("scouting/multicast/enabled")) is False  # Zenoh's own default is true
    assert json.loads(c.get_json("listen/endpoints")) == [f"tcp/127.0.0.1:{cell.robots[0].port}"]
    assert json.loads(c.get_json("transport/auth/usrpwd/dictionary_file")) == str(tmp_path / "users")
    client = session_config(cell, connect=("tcp/127.0.0.1:1",))
    assert json.loads(client.get_json("listen/endpoints")) == []  # a command line listens nowhere


BAD = [  # (what to change in a valid two-robot file, the key path named, words of the expectation)
    (lambda s: s.replace("[cell]", "[cell]\nbridge_priority = 99", 1), "cell.bridge_priority", "98"),
    (lambda s: s.replace("[cell]", "[cell]\nbridge_priority = 1.5", 1), "cell.bridge_priority", "integer"),
    (lambda s: s.replace('name = "r1"', 'name = "r/1"'), "robots[1].name", "Zenoh key chunk"),
    (lambda s: s.replace('name = "r1"', 'name = "r0"'), "robots[1].name", "is taken"),
    (lambda s: s.replace('sim = true', 'sim = true\nspeed = 3', 1), "robots[0].speed", "unknown key"),
    (lambda s: s.replace(re.findall(r"port = \d+", s)[1], re.findall(r"port = \d+", s)[0]), "robots[1].port",
     "is taken"),
    (lambda s: s.replace('port = ', 'port = 80 #', 1), "robots[0].port", "≥ 1024"),
    (lambda s: s.replace('sim = true', 'sim = true\nhost = "127.0.0.256"', 1), "robots[0].host", "IPv4"),
    (lambda s: s.replace('observers = ["viewer"]', 'observers = ["tester"]'), "auth.observers", "not the cell's user"),
    (lambda s: s.replace('dictionary_file = "users"', 'dictionary_file = "nope"'), "auth.dictionary_file",
     "not found"),
    (lambda s: s.replace('config = "', 'config = "missing/', 1), "robots[0].config", "not found"),
    (lambda s: s + '\n[zenoh]\nconnect = ["udp/224.0.0.224:7446"]\n', "zenoh.connect", "tcp/10.0.0.2:7447"),
    (lambda s: s + '\n[zenoh]\nhost = "localhost"\n', "zenoh.host", "IPv4"),
    (lambda s: s.replace('base = [0, 1, 0, 0, 0, 0]', 'base = [0, 1, 0]'), "robots[1].base", "6 numbers"),
    (lambda s: s + ZONE.replace('robot = "r1"', 'robot = "r7"'), "zones[0].regions[1].robot", "one of the cell"),
    (lambda s: s + ZONE.split("[[zones.regions]]")[0] + "[[zones.regions]]" + ZONE.split("[[zones.regions]]")[1],
     "zones[0].regions", "at least two robots"),
    (lambda s: s + ZONE.replace('hi = [-0.3, 0.9]', 'hi = [-0.9, 0.9]'), "zones[0].regions[1].lo", "lo < hi"),
    (lambda s: s + ZONE.replace('lo = [0.3, 0.2]', 'polygon = [[0, 0], [1, 0], [0, 1]]\nlo = [0.3, 0.2]'),
     "zones[0].regions[0].polygon", "either polygon"),
    (lambda s: s + ZONE.replace('name = "fixture"', 'name = "fixture"\nunit = "grad"'), "zones[0].unit", "'deg'"),
    (lambda s: s + ZONE.replace('joints = ["waist", "shoulder"]\nlo = [-0.8', 'joints = ["waist", "knee"]\nlo = [-0.8'),
     "zones[0].regions[1].joints", "unknown: 'knee'"),
    (lambda s: s.replace('name = "r1"', 'name = "arbiter"'), "robots[1].name", "other than 'arbiter'"),
    (lambda s: s + "\n[leases]\nduration_s = 0.0\n", "leases.duration_s", "0.05"),
    (lambda s: s + "\n[leases]\nmargin_s = -1\n", "leases.margin_s", "0"),
    (lambda s: s + "\n[leases]\nlength_s = 3\n", "leases.length_s", "unknown key"),
]
ZONE = '''
[[zones]]
name = "fixture"
[[zones.regions]]
robot = "r0"
joints = ["waist", "shoulder"]
lo = [0.3, 0.2]
hi = [0.8, 0.9]
[[zones.regions]]
robot = "r1"
joints = ["waist", "shoulder"]
lo = [-0.8, 0.2]
hi = [-0.3, 0.9]
'''


def test_a_robots_own_host_and_the_same_port_on_another_host(tmp_path):
    path = write_cell(tmp_path)
    text = path.read_text()
    port0 = re.findall(r"port = (\d+)", text)[0]
    text = text.replace(re.findall(r"port = \d+", text)[1], f'port = {port0}\nhost = "10.0.0.12"')
    path.write_text(text)
    cell = load_cell(path)
    assert [r.endpoint() for r in cell.robots] == [f"tcp/127.0.0.1:{port0}", f"tcp/10.0.0.12:{port0}"]


def test_cell_up_refuses_a_robot_the_cell_lacks(tmp_path, capsys):
    assert main(["cell", "up", str(write_cell(tmp_path)), "--robot", "r9"]) == 2
    assert "--robot: a robot of cell 'testcell' (r0, r1), got 'r9'" in capsys.readouterr().err


def test_a_valid_zone_loads_in_its_unit(tmp_path):
    path = write_cell(tmp_path)
    path.write_text(path.read_text() + ZONE)
    (zone,) = load_cell(path).zones
    assert zone.regions[1].part.joints == (0, 1) and zone.regions[1].part.lo.tolist() == [-0.8, 0.2]
    path.write_text(path.read_text().replace('name = "fixture"', 'name = "fixture"\nunit = "deg"')
                    .replace("lo = [-0.8, 0.2]", "lo = [-45, 10]").replace("hi = [-0.3, 0.9]", "hi = [-20, 50]"))
    part = load_cell(path).zones[0].regions[1].part
    assert part.lo == pytest.approx([-math.pi / 4, math.pi / 18])  # (waist and shoulder are revolute)
    assert load_cell(path, check_robots=False).zones == ()  # the commands to a running cell skip them


@pytest.mark.parametrize("change, key, words", BAD, ids=[b[1] for b in BAD])
def test_a_mistake_exits_2_naming_file_key_and_expectation(tmp_path, capsys, change, key, words):
    path = write_cell(tmp_path)
    path.write_text(change(path.read_text()))
    with pytest.raises(ConfigError) as e:
        load_cell(path)
    assert e.value.key_path == key and words in e.value.expected
    assert main(["cell", "up", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and key in err
