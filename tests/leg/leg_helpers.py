"""Paths and shared helpers of the leg tests (a uniquely named module: see tests/model)."""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TABLE3 = ROOT / "configs" / "leg" / "table3.toml"
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
from runtime_helpers import rtctl  # noqa: E402,F401  (re-exported)

CONFIGS = ROOT / "configs"
PATTERN = (1, 2, 3, 4, 1, 5, 1, 6)


def leg_runtime(hysteresis: bool = True, seed: int = 1, angle_noise: float = 0.3):
    """The shipped embedded leg configuration built (nothing opened): (board, controller)."""
    from rtctl.config import load_config
    from rtctl.runtime import build

    text = (CONFIGS / "leg_sim.toml").read_text().replace('description = "robots/', f'description = "{CONFIGS}/robots/')
    text = text.replace('table = "leg/table3.toml"', f'table = "{CONFIGS}/leg/table3.toml"\nhysteresis = {str(hysteresis).lower()}')
    text = text.replace("seed = 1", f"seed = {seed}").replace("angle_noise = 0.3", f"angle_noise = {angle_noise}").replace('path = "../runs/leg_sim.msgpack"', "")
    import tempfile

    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
        f.write(text)
    rt = build(load_config(f.name))
    return rt.devices[0], rt.controllers[0]


def walk(seconds: float, **kw):
    """Run the board and the automaton tick by tick (read → update → write) for ``seconds`` of
    plant time; the automaton's state sequence (each change once) and the gate toggles."""
    import numpy as np

    board, ctl = leg_runtime(**kw)
    board.configure()
    board.activate()
    ctl.reset(None)
    ticks = int(round(seconds / board.period))
    seq = [int(ctl.data[4])]
    toggles = 0
    gates = ctl.data[5:].copy()
    for _ in range(ticks):
        board.read(0.0)
        ctl.update(0.0, None, None, None)
        board.write(0.0)
        if ctl.data[4] != seq[-1]:
            seq.append(int(ctl.data[4]))
        toggles += int(np.count_nonzero(ctl.data[5:] != gates))
        gates[:] = ctl.data[5:]
    board.close()
    return seq, toggles


def pattern_prefix(seq) -> int:
    """How many states of ``seq`` follow (1 2 3 4 1 5 1 6)ⁿ from the start (state 1)."""
    n = 0
    while n < len(seq) and seq[n] == PATTERN[n % len(PATTERN)]:
        n += 1
    return n


def one_jump_circuit(table, circuit):
    """Table 3's circuit synthesised again with 1 → 2 taken in one jump (000 → 110) instead of
    its route: under 1 → 2's gate vector state 1's code excites Q1 and Q2 at once."""
    from rtctl.logic.assign import Assignment
    from rtctl.logic.flow import flow_table
    from rtctl.logic.synth import synthesise

    a = circuit.assignment
    routes = dict(a.routes)
    key = next(k for k, p in routes.items() if k[0] == 1 and a.state_of(p[-1]) == 2)
    routes[key] = (a.codes[1], a.codes[2])
    return synthesise(flow_table(table), Assignment(3, a.codes, routes))


def table_refusal(tmp_path, text):
    """The configuration error loading the event table ``text`` raises (it must raise one)."""
    import pytest

    from rtctl.errors import ConfigError
    from rtctl.logic import load_table

    path = tmp_path / "t.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_table(path)
    return e.value


def leg_config(tmp_path, **replace):
    """configs/leg_sim.toml in ``tmp_path`` with text replacements (old → new, each present),
    its paths made absolute and its telemetry off → the new file's path."""
    text = (CONFIGS / "leg_sim.toml").read_text().replace('description = "robots/', f'description = "{CONFIGS}/robots/')
    text = text.replace('table = "leg/table3.toml"', f'table = "{CONFIGS}/leg/table3.toml"')
    text = text.replace('path = "../runs/leg_sim.msgpack"', "")
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "leg.toml"
    path.write_text(text)
    return path
