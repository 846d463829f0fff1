"""Issue 26 items 1 and 3: `rtctl leg compile` ends on every table it accepts — a race-free
circuit, proved, or exit 2 saying why — and refuses with exit 2 the tables beyond its limits.

A 9-state chain used to search for more than 5 minutes; the search is now a bounded branch and
bound (rtctl.logic.assign). The subprocess timeout is a hang guard, not a benchmark: the times
are measured by `rtctl bench leg` and quoted in docs/leg_automaton.md."""
from __future__ import annotations

import subprocess
import sys

import pytest

from rtctl.errors import ConfigError
from rtctl.logic.assign import AssignmentError, candidate_assignments
from rtctl.logic.flow import flow_table
from rtctl.logic.synth import compile_table
from rtctl.logic.synthetic import synthetic_table
from rtctl.logic.table import MAX_GATES, MAX_ROWS, MAX_STATES, load_table

HANG_GUARD_S = 120
ADVERSARIAL_GUARD_S = 60  # ~7 s here; the old minimiser took 64 s (complete) and 49 s (random 200 rows, 11 gates)


def _compile(path, timeout=HANG_GUARD_S):
    return subprocess.run([sys.executable, "-m", "rtctl.cli", "leg", "compile", str(path)], capture_output=True,
                          text=True, timeout=timeout)


@pytest.mark.parametrize("kind, states, gates", [("chain", 9, 8), ("star", 16, 5), ("random", 16, 6)])
def test_a_table_within_the_limits_compiles_to_a_proved_circuit(tmp_path, kind, states, gates):
    path = tmp_path / f"{kind}{states}.toml"
    path.write_text(synthetic_table(kind, states, gates))
    r = _compile(path)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "circuit = automaton" in r.stdout and "no critical race" in r.stdout and "Settles within" in r.stdout


@pytest.mark.parametrize("gates", [8, 11])
def test_the_densest_table_ends_within_the_hang_guard(tmp_path, gates):
    """Every state left for every other (240 rows, 5 flip-flops, 11 gates + 5 = the minimiser's 16
    inputs at most): the largest functions an accepted table gives. It must end — with a proved
    circuit, or exit 2 saying why — well inside the guard (issue 26 item 1: ≤ 10 s)."""
    path = tmp_path / "complete16.toml"
    path.write_text(synthetic_table("complete", 16, gates))
    r = _compile(path, ADVERSARIAL_GUARD_S)
    if r.returncode == 2:
        assert "configuration error" in r.stderr and "Traceback" not in r.stderr, r.stderr
    else:
        assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
        assert "no critical race" in r.stdout and "Settles within" in r.stdout, r.stdout[-2000:]


def test_more_rows_than_the_limit_exit_2_naming_rows(tmp_path):
    """Two states taking turns over Gray-coded gate vectors: valid but for its length."""
    rows = [f'[{k + 1}, "{k ^ k >> 1:09b}", "{k & 1}", {1 + (k & 1)}],' for k in range(MAX_ROWS + 2)]
    path = tmp_path / "long.toml"
    gates = ", ".join(f'"g{i}"' for i in range(9))
    path.write_text(f'name = "long"\ncyclic = true\ngates = [{gates}]\nactuators = ["A"]\nrows = [\n'
                    + "\n".join(rows) + '\n]\n\n[outputs]\n1 = "0"\n2 = "1"\n')
    r = _compile(path)
    assert r.returncode == 2 and "rows" in r.stderr and f"at most {MAX_ROWS} rows" in r.stderr, r.stderr


@pytest.mark.parametrize("gates", [MAX_GATES + 1, 16])
def test_more_gates_than_the_minimiser_takes_exit_2_naming_gates(tmp_path, gates):
    path = tmp_path / "wide.toml"
    path.write_text(synthetic_table("chain", 4, gates))
    r = _compile(path)
    assert r.returncode == 2 and "gates" in r.stderr and f"at most {MAX_GATES} gates" in r.stderr, r.stderr


def test_more_states_than_the_search_is_bounded_for_exit_2_naming_rows(tmp_path):
    path = tmp_path / "many.toml"
    path.write_text(synthetic_table("chain", MAX_STATES + 1, 5))
    r = _compile(path)
    assert r.returncode == 2 and "rows" in r.stderr and f"at most {MAX_STATES} states" in r.stderr, r.stderr


def test_a_spent_search_budget_says_so_and_is_a_configuration_error(tmp_path, monkeypatch):
    path = tmp_path / "star.toml"
    path.write_text(synthetic_table("star", 9, 5))
    table = load_table(path)
    with pytest.raises(AssignmentError, match="within the search budget"):
        candidate_assignments(flow_table(table), budget=3)
    monkeypatch.setattr("rtctl.logic.assign.SEARCH_BUDGET", 3)
    monkeypatch.setattr(candidate_assignments, "__defaults__", (3, None))
    with pytest.raises(ConfigError) as e:
        compile_table(table)
    assert e.value.key_path == "rows" and "search budget" in e.value.expected
