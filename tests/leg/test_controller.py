"""The leg_automaton controller: configuration errors, allocation-free update, and the safe
state (both joints locked) in the tick a fault is found."""
import itertools
from types import SimpleNamespace

import numpy as np
import pytest

from allocations import growth_and_peak
from leg_helpers import leg_config, leg_runtime
from rtctl.config import load_config
from rtctl.daemon import Daemon
from rtctl.errors import ConfigError
from rtctl.runtime import build
from rtctl.telemetry import read


@pytest.mark.parametrize("old, new, key, words", [
    ('gates.K_d3 = { channel = "knee",  threshold = 40.0, hysteresis = 2.0 }\n', "", "controllers[0].gates.K_d3", "missing"),
    ('channel = "ankle"', 'channel = "elbow"', "controllers[0].gates.a_d.channel", "one of"),
    ('devices = ["board"]', "devices = []", "controllers[0].devices", "exactly one leg board"),
    ('hysteresis = 2.0, below = true', 'hysteresis = -2.0, below = true', "controllers[0].gates.h_d2.hysteresis", "≥ 0"),
])
def test_bad_controller_options_exit_2_naming_the_key(tmp_path, old, new, key, words):
    with pytest.raises(ConfigError) as e:
        build(load_config(leg_config(tmp_path, **{old: new})))
    assert e.value.key_path == key and words in e.value.expected, e.value


@pytest.mark.parametrize("passes", [1, 2, 6])
def test_a_settle_limit_below_what_the_circuit_needs_is_refused_naming_the_need(tmp_path, passes):
    """Issue 26 item 5: a settle limit below the circuit's need used to pass check and fault at
    0.1 s. The shipped circuit (guard semantics, issue 29) chains exits within one settle: its
    longest path (a chain of exits on one vector) is 6 flip-flop changes, so it needs 7 passes
    (the exact-vector circuit needed 3)."""
    with pytest.raises(ConfigError) as e:
        build(load_config(leg_config(tmp_path, **{'table = "': f'max_passes = {passes}\ntable = "'})))
    assert e.value.key_path == "controllers[0].max_passes" and "at least 7" in e.value.expected, e.value


def test_the_settle_limit_needed_is_the_longest_route_plus_one_confirming_pass(tmp_path):
    """Measured on the circuit itself: from every state under every gate vector, the emulated
    circuit with exactly that limit settles where the automaton goes, and with one pass less
    some transition does not."""
    from dataclasses import replace

    from rtctl.logic.emulate import NOT_SETTLED, Emulator

    ctl = build(load_config(leg_config(tmp_path))).controllers[0]
    needed = ctl.circuit.settle_passes
    assert ctl.cm.max_passes == needed + 1  # the default keeps one spare
    flow, a = ctl.circuit.flow, ctl.circuit.assignment

    def unsettled(limit):
        em = Emulator(replace(ctl.cm, max_passes=limit))
        bad = 0
        for s in flow.states:
            for x in range(1 << flow.n_gates):
                em.code = a.codes[s]
                bad += em.apply(x) == NOT_SETTLED
        return bad

    assert unsettled(needed) == 0 and unsettled(needed - 1) > 0


def test_update_allocates_nothing():
    board, ctl = leg_runtime()
    board.configure()
    board.activate()
    ctl.reset(None)
    for _ in range(2000):  # into the walk, compiled paths loaded
        board.read(0.0)
        ctl.update(0.0, None, None, None)
        board.write(0.0)
    ticks = []
    for _ in range(3000):  # a gait's worth of channels, replayed below under tracemalloc
        board.read(0.0)
        ticks.append(board.channels.copy())
        board.write(0.0)
    ch, rows = board.channels, itertools.cycle(ticks)

    def update():
        ch[:] = next(rows)
        ctl.update(0.0, None, None, None)

    growth, peak = growth_and_peak(update, len(ticks))
    assert growth <= 64 and peak < 512, (growth, peak)


def test_a_circuit_that_does_not_settle_locks_both_joints_in_the_same_tick(tmp_path):
    """A settle limit of 1 leaves no pass to confirm a state change: the first transition is a
    fault. (The configuration refuses such a limit; set here as a circuit that cannot settle.)"""
    path = leg_config(tmp_path)
    cfg = load_config(path)
    args = SimpleNamespace(telemetry=str(tmp_path / "t.msgpack"), socket=str(tmp_path / "s.sock"), enforce_rt=False,
                           duration=3.0, summary=None, log_level="error", realtime_factor=0.0)
    from dataclasses import replace

    cfg = replace(cfg, loop=replace(cfg.loop, realtime_factor=0.0))
    rt = build(cfg)
    ctl = rt.controllers[0]
    ctl.cm = replace(ctl.cm, max_passes=1)
    d = Daemon(cfg, rt, args)
    assert d.run() == 3
    fault = d.safety.faults[0]
    assert "did not settle" in fault.reason
    tel = read(args.telemetry)
    rows = np.flatnonzero(tel["t"] >= fault.t)
    assert tel["leg_actions"][rows[0]].tolist() == [0, 0]  # locked in the fault's own tick
    assert np.all(tel["leg_actions"][rows] == 0)
    assert not np.all(tel["leg_actions"][: rows[0]] == 0)  # (it was walking before)
