"""The event table: loaded as data, and every kind of bad table exits 2 naming the row."""
import pytest

from leg_helpers import TABLE3, rtctl
from rtctl.errors import ConfigError
from rtctl.logic import load_table

PAPER_ROWS = [  # Table 3 as printed (gates t_d h_d K_d1 K_d2 K_d3 a_d h_d1 h_d2 | K1 K2 A1 A2 | state)
    "00100100 1111 1", "00100110 1100 2", "00100110 1100 2", "10100010 1100 2", "11100010 0100 3",
    "11000010 1110 4", "11000000 1110 4", "11000100 1111 1", "11000101 1011 5", "10111100 1111 1",
    "00111100 0111 6", "00110100 0111 6"]


def test_table3_is_the_papers(table3):
    assert table3.gates == ("t_d", "h_d", "K_d1", "K_d2", "K_d3", "a_d", "h_d1", "h_d2")
    assert table3.actuators == ("K1", "K2", "A1", "A2")
    rows = [f"{table3.gate_bits(x)} {table3.actuator_bits(table3.outputs[s])} {s}"
            for x, s in zip(table3.inputs, table3.states)]
    assert rows == PAPER_ROWS
    assert table3.steps == tuple(range(1, 13)) and table3.cyclic


def _variant(tmp_path, old, new, count=1):
    text = TABLE3.read_text()
    assert text.count(old) >= count, old
    path = tmp_path / "t.toml"
    path.write_text(text.replace(old, new, count))
    return path


@pytest.mark.parametrize("old, new, key, words", [
    ('[ 4, "1010 0010", "1100", 2]', '[ 4, "1010 001", "1100", 2]', "rows[3][1]", "8 gate bits"),
    ('[ 4, "1010 0010", "1100", 2]', '[ 4, "1010 0010", "1100"]', "rows[3]", "4 columns"),
    ('[ 9, "1100 0101", "1011", 5]', '[ 9, "1100 0101", "10111", 5]', "rows[8][2]", "4 actuator bits"),
    # row 12 repeats row 11's gates in state 6 but says state 2: same state and input, two next states
    ('[12, "0011 0100", "0111", 6]', '[12, "0011 1100", "1100", 2]', "rows[11]", "conflict with rows[10]"),
    ('[ 6, "1100 0010", "1110", 4]', '[ 6, "1100 0010", "1111", 4]', "rows[5][2]", "function of the state"),
])
def test_bad_tables_name_the_row(tmp_path, old, new, key, words):
    with pytest.raises(ConfigError) as e:
        load_table(_variant(tmp_path, old, new))
    assert words in e.value.expected and e.value.key_path == key, e.value


def test_state_without_exit_names_its_last_row(tmp_path):
    # (in a cyclic table every state is left somewhere in the cycle) a non-cyclic one: nothing
    # leaves state 6 after the last row
    path = _variant(tmp_path, "cyclic = true", "cyclic = false")
    with pytest.raises(ConfigError) as e:
        load_table(path)
    assert e.value.key_path == "rows[11]" and "exit from state 6" in e.value.expected


def test_cli_exits_2_naming_file_and_row(tmp_path):
    path = _variant(tmp_path, '[ 4, "1010 0010", "1100", 2]', '[ 4, "1010 0010", "1100", 2, 7]')
    result = rtctl("leg", "compile", path)
    assert result.returncode == 2, result.stderr
    assert str(path) in result.stderr and "rows[3]" in result.stderr and "4 columns" in result.stderr
