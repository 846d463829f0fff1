"""The leg automaton's threshold gates as Schmitt triggers, from the shipped configuration read
independently (tomllib): a gate with threshold c and hysteresis h turns on past c + h/2 and off
past c − h/2 (mirrored for ``below``); and ``reset`` forgets the gates' memory, so that a reset
controller answers as a new one."""
import math
import tomllib

import numpy as np
import pytest

from leg_helpers import CONFIGS, leg_runtime
from rtctl.control.leg_automaton import GATE0
from rtctl.hal.leg_board import CHANNELS

GATES = tomllib.loads((CONFIGS / "leg_sim.toml").read_text())["controllers"][0]["gates"]
ANGLES = {"hip", "knee", "ankle"}
NEUTRAL = np.array([0.0, math.radians(10.0), math.radians(5.0), 0.05, 0.05])  # hip, knee, ankle (rad), toe, heel


@pytest.fixture(scope="module")
def runtime():
    return leg_runtime()


def _gate_after(ctl, name, channel, value):
    """The gate's bit after one tick with the channel at ``value``."""
    ctl.board.channels[channel] = value
    ctl.update(0.0, None, None, None)
    return int(ctl.data[GATE0 + ctl.table.gates.index(name)])


@pytest.mark.parametrize("name", list(GATES))
def test_each_gate_switches_at_its_threshold_plus_and_minus_half_its_hysteresis(runtime, name):
    _, ctl = runtime
    spec = GATES[name]
    scale = math.pi / 180.0 if spec["channel"] in ANGLES else 1.0
    c, h = spec["threshold"] * scale, spec["hysteresis"] * scale
    sense = -1.0 if spec.get("below") else 1.0
    channel = CHANNELS.index(spec["channel"])
    ctl.reset(None)
    ctl.board.channels[:] = NEUTRAL
    step = h / 400
    # the error e = sense · (value − c) swept up from −h to +h, then back down (off the switching points by step/2)
    errors = -h + step / 2 + step * np.arange(800)
    first_on = next(e for e in errors if _gate_after(ctl, name, channel, c + sense * e))
    first_off = next(e for e in errors[::-1] if not _gate_after(ctl, name, channel, c + sense * e))
    assert h / 2 < first_on <= h / 2 + step  # on just past c + h/2, not before
    assert -h / 2 - step <= first_off < -h / 2  # off just past c − h/2, not before


def test_reset_forgets_the_gate_memory_and_answers_as_a_new_controller():
    _, used = leg_runtime()
    _, fresh = leg_runtime()
    toe = CHANNELS.index("toe")
    for ctl in (used, fresh):
        ctl.board.channels[:] = NEUTRAL
    used.board.channels[toe] = 0.5  # well past the toe gate's on-point (0.20): the gate turns on
    used.update(0.0, None, None, None)
    assert used.data[GATE0 + used.table.gates.index("t_d")] == 1
    used.reset(None)
    # inside the toe gate's band (0.10 … 0.20): a Schmitt trigger keeps what it had — a new one had nothing
    for ctl in (used, fresh):
        ctl.board.channels[toe] = 0.15
        ctl.update(0.0, None, None, None)
    np.testing.assert_array_equal(used.data, fresh.data)
    np.testing.assert_array_equal(used.board.actions, fresh.board.actions)
    assert used.data[GATE0 + used.table.gates.index("t_d")] == 0
