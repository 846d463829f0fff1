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
from rtctl.logic.table import MAX_GATES, MAX_STATES, load_table

HANG_GUARD_S = 120


def _compile(path):
    return subprocess.run([sys.executable, "-m", "rtctl.cli", "leg", "compile", str(path)], capture_output=True,
                          text=True, timeout=HANG_GUARD_S)


@pytest.mark.parametrize("kind, states, gates", [("chain", 9, 8), ("star", 16, 5), ("random", 16, 6)])
def test_a_table_within_the_limits_compiles_to_a_proved_circuit(tmp_path, kind, states, gates):
    path = tmp_path / f"{kind}{states}.toml"
    path.write_text(synthetic_table(kind, states, gates))
    r = _compile(path)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "circuit = automaton" in r.stdout and "no critical race" in r.stdout and "Settles within" in r.stdout


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
    monkeypatch.setattr(candidate_assignments, "__defaults__", (3,))
    with pytest.raises(ConfigError) as e:
        compile_table(table)
    assert e.value.key_path == "rows" and "search budget" in e.value.expected
