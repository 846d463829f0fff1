"""The leg automaton's actions are the table's Moore outputs: K1 K2 the knee's code and A1 A2
the ankle's, each 00 hold, 01 decrease, 10 increase, 11 release (configs/leg/table3.toml)."""
from leg_helpers import TABLE3, leg_runtime
from rtctl.logic import load_table

ACTUATOR_CODES = {"00": 0, "01": 1, "10": 2, "11": 3}


def test_the_leg_actions_are_the_states_outputs_knee_then_ankle():
    table = load_table(TABLE3)
    expected = {s: (ACTUATOR_CODES[f"{z:04b}"[::-1][:2]], ACTUATOR_CODES[f"{z:04b}"[::-1][2:]])
                for s, z in table.outputs.items()}
    text = TABLE3.read_text().split("[outputs]")[1]  # the same outputs, read from the file's text
    for line in filter(None, (ln.split("#")[0].strip() for ln in text.splitlines())):
        state, bits = line.split(" = ")
        bits = bits.strip('"')
        assert expected[int(state)] == (ACTUATOR_CODES[bits[:2]], ACTUATOR_CODES[bits[2:]]), line
    board, ctl = leg_runtime()
    board.configure()
    board.activate()
    ctl.reset(None)
    seen = set()
    for _ in range(6000):  # a few gait cycles: every state
        board.read(0.0)
        ctl.update(0.0, None, None, None)
        state = int(ctl.internals["leg_state"][0])
        assert tuple(int(a) for a in board.actions) == expected[state], state
        seen.add(state)
        board.write(0.0)
    assert seen == set(expected)
