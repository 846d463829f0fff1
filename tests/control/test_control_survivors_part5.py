"""Tests for control mutants that survived the fast pass of the run over every mutant
(docs/mutation/control.md), part 5: the leg automaton's gates and options, against its module
docstring (rtctl/control/leg_automaton.py, configs/leg_sim.toml):

* each gate a Schmitt trigger: on above threshold + h/2, off below threshold − h/2, its state
  held in between, read channel by channel (angles in degrees, loads in body weights, ``below``
  gates mirrored); ``hysteresis = false`` (or h = 0): the plain comparator, on when S_c − S_r > 0;
* the gates start off after a reset; ``leg_settle`` counts the passes only in a tick that
  changed the state; ``leg_state`` is one value;
* options: ``hysteresis`` on by default, a gate's ``hysteresis`` 0 by default, ``max_passes`` at
  least what the circuit needs (and exactly that is enough), a bad table named as such, exactly
  one device and it a leg board, the devices given named in the error.
"""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "leg"))
from leg_helpers import CONFIGS, leg_config  # noqa: E402
from rtctl.config import load_config  # noqa: E402
from rtctl.control.leg_automaton import LegAutomaton  # noqa: E402
from rtctl.errors import ConfigError  # noqa: E402
from rtctl.runtime import build  # noqa: E402

DEG = math.pi / 180.0


def _leg(tmp_path, **replace):
    """(board, controller) of configs/leg_sim.toml with text replacements (no option added)."""
    rt = build(load_config(leg_config(tmp_path, **replace)))
    c = rt.controllers[0]
    c.reset(None)
    return rt.devices[0], c


def _gate_trace(board, c, gate, channel, values):
    """The gate's bit after each tick with ``channel`` at each of ``values`` (the others at 0)."""
    g = c.table.gates.index(gate)
    out = []
    for v in values:
        board.channels[:] = 0.0
        board.channels[channel] = v
        c.update(0.0, None, None, None)
        out.append(int(c.internals["leg_gates"][g]))
    return out


def test_a_below_gate_on_the_hip_is_a_schmitt_trigger_in_degrees(tmp_path):
    """h_d2: hip below −11° with h = 2° (no ``hysteresis`` option: on by default) — on under
    −12°, off over −10°, held in between."""
    board, c = _leg(tmp_path)
    hip = [-11.95, -12.05, -11.0, -10.05, -9.95, -11.0]
    assert _gate_trace(board, c, "h_d2", 0, [v * DEG for v in hip]) == [0, 1, 1, 1, 0, 0]


def test_a_load_gate_is_a_schmitt_trigger_in_body_weights(tmp_path):
    """t_d: toe above 0.15 body weights with h = 0.1 — on over 0.2, off under 0.1."""
    board, c = _leg(tmp_path)
    assert _gate_trace(board, c, "t_d", 3, [0.19, 0.21, 0.15, 0.11, 0.09, 0.15]) == [0, 1, 1, 1, 0, 0]


def test_the_band_edges_hold_and_the_gates_start_off(tmp_path):
    """Exactly at threshold ± h/2 a gate keeps its state ("above", "below" are strict); dyadic
    numbers make the edges exact. After a reset every gate is off, so a channel inside the band
    leaves its gate off."""
    board, c = _leg(tmp_path)
    g = c.table.gates.index("K_d1")
    c.gates[:, g] = [1.0, 0.5, 0.25, 1.0]  # knee channel, threshold 0.5, h/2 = 0.25, above
    assert int(c.internals["leg_gates"].sum()) == 0
    knee = [0.5, 0.75, 0.875, 0.75, 0.625, 0.25, 0.125, 0.25]
    assert _gate_trace(board, c, "K_d1", 1, knee) == [0, 0, 1, 1, 1, 1, 0, 0]
    c.gates[2, g] = 0.0  # h = 0: the plain comparator, off exactly at the threshold
    assert _gate_trace(board, c, "K_d1", 1, [0.75, 0.5, 0.625, 0.5]) == [1, 0, 1, 0]


@pytest.mark.parametrize("gate, channel, values, expected", [
    ("t_d", 3, [0.16, 0.15, 0.1500001, 0.14], [1, 0, 1, 0]),
    ("K_d1", 1, [5.01 * DEG, 4.99 * DEG, 5.2 * DEG, 0.0], [1, 0, 1, 0]),
    ("h_d2", 0, [-11.01 * DEG, -10.99 * DEG, -12.0 * DEG, 0.0], [1, 0, 1, 0]),
])
def test_without_hysteresis_a_gate_is_the_plain_comparator(tmp_path, gate, channel, values, expected):
    """Table 2: on when S_c − S_r > 0 (for a ``below`` gate S_r − S_c > 0), off at equality."""
    board, c = _leg(tmp_path, **{'semantics = "guard"': 'semantics = "guard"\nhysteresis = false'})
    assert _gate_trace(board, c, gate, channel, values) == expected


def test_a_gate_without_hysteresis_given_is_a_plain_comparator(tmp_path):
    board, c = _leg(tmp_path, **{'threshold = 40.0, hysteresis = 2.0 }': 'threshold = 40.0 }'})
    assert _gate_trace(board, c, "K_d3", 1, [40.1 * DEG, 39.9 * DEG]) == [1, 0]


def test_leg_settle_counts_passes_only_in_a_tick_that_changed_the_state(tmp_path):
    board, c = _leg(tmp_path)
    assert c.internals["leg_state"].shape == c.internals["leg_settle"].shape == (1,)  # one channel each
    board.configure()
    board.activate()
    c.reset(None)
    changed = 0
    for _ in range(3000):
        before = int(c.internals["leg_state"][0])
        board.read(0.0)
        c.update(0.0, None, None, None)
        board.write(0.0)
        moved = int(c.internals["leg_state"][0]) != before
        changed += moved
        assert (int(c.internals["leg_settle"][0]) > 0) == moved
    board.close()
    assert changed >= 4


def test_max_passes_equal_to_the_need_is_enough_and_the_message_names_the_path(tmp_path):
    """The shipped circuit's longest path is 6 flip-flop changes: it needs 7 passes."""
    _, c = _leg(tmp_path, **{'table = "': 'max_passes = 7\ntable = "'})
    assert c.cm.max_passes == 7
    with pytest.raises(ConfigError) as e:
        _leg(tmp_path, **{'table = "': 'max_passes = 6\ntable = "'})
    assert "longest path is 6 flip-flop changes" in e.value.expected


def test_a_bad_event_table_is_named(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("gates = 3\n")
    with pytest.raises(ConfigError) as e:
        _leg(tmp_path, **{f'table = "{CONFIGS}/leg/table3.toml"': f'table = "{bad}"'})
    assert e.value.key_path == "controllers[0].table" and "a valid event table" in e.value.expected


def test_bind_needs_exactly_one_device_and_it_a_leg_board(tmp_path):
    board, c = _leg(tmp_path)
    with pytest.raises(TypeError, match="exactly one leg board"):
        c.bind({"board": board, "other": object()})
    c.bind({"board": board})
    assert c.board is board


def test_constructed_directly_it_runs_every_tick_and_follows_no_reference(tmp_path):
    """Controller's docstring: the leg's automaton drives its joints from its gait
    (``follows_reference`` false: no tracking error); the divisor defaults to every tick."""
    _, c = _leg(tmp_path)
    direct = LegAutomaton("leg", c.model, c.table, c.gates.copy(), semantics="guard")
    assert direct.divisor == 1 and not direct.follows_reference
    np.testing.assert_array_equal(direct.internals["leg_gates"], 0)


@pytest.mark.parametrize("devices, named", [({}, "none"), ({"left": 0, "right": 1}, "left, right")])
def test_binding_without_exactly_one_board_names_the_devices_given(tmp_path, devices, named):
    board, c = _leg(tmp_path)
    given = {k: board for k in devices}
    with pytest.raises(TypeError, match=f"needs exactly one leg board in devices, got {named}$"):
        c.bind(given)
