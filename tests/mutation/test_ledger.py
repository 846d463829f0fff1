"""The mutation runner's ledger and its unevaluated sites (tests/mutation/ledger.py,
unevaluated.py) on a scratch module, with cosmic-ray's own ``init`` making the mutants —
the positions and (operator, occurrence) keys are cosmic-ray's, not this code's."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import ledger
from renewal import record_code
from run import run_again, runnable, skip_other_shards

cosmic_ray = pytest.importorskip("cosmic_ray", reason="the mutation extra is not installed ('.[mutation]')")
from cosmic_ray.work_db import WorkDB, use_db  # noqa: E402
from cosmic_ray.work_item import TestOutcome as Outcome, WorkerOutcome, WorkResult  # noqa: E402

MODULE = '''\
"""A scratch module."""
from __future__ import annotations

LIMIT = 3 | 4


def clamp(x: float | int, é: int = 2 | 1, note: str = "éééééééééééé") -> float | None:
    return min(x | 1, LIMIT) if x > 0 else None
'''


def init(tree: Path, source: str) -> Path:
    """``cosmic-ray init`` of ``tree/pkg/mod.py`` holding ``source``; the session database."""
    (tree / "pkg").mkdir(parents=True, exist_ok=True)
    (tree / "pkg" / "mod.py").write_text(textwrap.dedent(source))
    config, db = tree / "cr.toml", tree / "session.sqlite"
    config.write_text(f'[cosmic-ray]\nmodule-path = ["{tree / "pkg" / "mod.py"}"]\ntimeout = 10.0\n'
                      'excluded-modules = []\ntest-command = "true"\n\n[cosmic-ray.distributor]\nname = "local"\n')
    db.unlink(missing_ok=True)
    subprocess.run([sys.executable, "-m", "cosmic_ray.cli", "init", str(config), str(db)], cwd=tree, check=True,
                   capture_output=True)
    record_code(db)
    return db


def items(db: Path) -> list:
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        return list(work_db.work_items)


def mutated_text(item) -> str:
    m = item.mutations[0]
    lines = Path(m.module_path).read_text().splitlines()
    assert m.start_pos[0] == m.end_pos[0]
    return lines[m.start_pos[0] - 1][m.start_pos[1]:m.end_pos[1]]


def bit_or_lines(db: Path, keep: list) -> dict[int, int]:
    """line → how many of its ``|`` → ``&`` mutants are in ``keep``."""
    kept = {i.job_id for i in keep}
    found: dict[int, int] = {}
    for i in items(db):
        if i.mutations[0].operator_name.endswith("BitOr_BitAnd"):
            line = i.mutations[0].start_pos[0]
            found[line] = found.get(line, 0) + (i.job_id in kept)
    return found


def test_a_mutant_inside_an_annotation_is_left_out_only_where_annotations_are_postponed(tmp_path):
    db = init(tmp_path, MODULE)
    assert all(mutated_text(i) == "|" for i in items(db) if i.mutations[0].operator_name.endswith("BitOr_BitAnd"))
    # line 7: the two annotations' out, the default's in (after non-ASCII text: cosmic-ray's
    # columns are characters, ast's bytes); lines 4 and 8: code
    assert bit_or_lines(db, runnable(items(db))) == {4: 1, 7: 1, 8: 1}

    eager = tmp_path / "eager"
    db = init(eager, MODULE.replace("from __future__ import annotations\n", ""))
    assert bit_or_lines(db, runnable(items(db))) == {3: 1, 6: 3, 7: 1}  # (evaluated: a mutant can fail there)


HOLDER = '''\
from __future__ import annotations


class Holder:
    def __init__(self):
        self.frames: list[int | None] = [None] * (2 | 1)
'''


def test_an_annotated_assignments_annotation_is_left_out_and_its_value_kept(tmp_path):
    db = init(tmp_path, HOLDER)
    assert bit_or_lines(db, runnable(items(db))) == {6: 1}
    eager = tmp_path / "eager"
    db = init(eager, HOLDER.replace("from __future__ import annotations\n", ""))
    assert bit_or_lines(db, runnable(items(db))) == {5: 2}


def finish(db: Path, outcome: dict[str, str]) -> None:
    """Give each item the verdict ``outcome[mutated operator's name]``, "survived" by default."""
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        for item in work_db.work_items:
            v = outcome.get(item.mutations[0].operator_name.rsplit("/", 1)[-1], "survived")
            work_db.set_result(item.job_id, WorkResult(
                worker_outcome=WorkerOutcome.NORMAL, output="MUTATION-TIMED-OUT" if v == "timed_out" else "",
                test_outcome=Outcome.SURVIVED if v == "survived" else Outcome.KILLED))


GT = "ReplaceComparisonOperator_Gt_GtE"


def test_a_new_run_takes_kills_and_time_outs_on_the_same_code_and_runs_survivors_again(tmp_path):
    folder, first, second = tmp_path / "ledger", tmp_path / "a", tmp_path / "b"
    db = init(first, MODULE)
    finish(db, {GT: "killed", "NumberReplacer": "timed_out"})
    path, counts = ledger.save_run("scratch", first, "abc1234", folder)
    total = len(items(db))
    n_numbers = sum(i.mutations[0].operator_name.endswith("NumberReplacer") for i in items(db))
    assert counts == {"killed": 1, "timed_out": n_numbers, "survived": total - 1 - n_numbers}
    assert ledger.load("scratch", folder)["modules"]["pkg/mod.py"]["tests_at"] == "abc1234"

    # a copy elsewhere, its docstring changed: the same code, the same mutants
    db = init(second, MODULE.replace("A scratch module.", "A scratch module, described at length."))
    assert ledger.take("scratch", second, db, folder) == {"killed": 1, "timed_out": n_numbers}
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        pending = list(work_db.pending_work_items)
        taken = {i.mutations[0].operator_name.rsplit("/", 1)[-1] for i, _ in work_db.completed_work_items}
    assert len(pending) == total - 1 - n_numbers and taken == {GT, "NumberReplacer"}
    assert all(ledger.verdict(r) == "timed_out" for i, r in work_db_results(db) if "Number" in i)


def work_db_results(db: Path):
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        return [(i.mutations[0].operator_name, r) for i, r in work_db.completed_work_items]


def test_changed_code_takes_nothing_and_replaces_the_entry(tmp_path):
    folder, first, second = tmp_path / "ledger", tmp_path / "a", tmp_path / "b"
    finish(init(first, MODULE), {GT: "killed"})
    ledger.save_run("scratch", first, "abc1234", folder)
    changed = MODULE.replace("x > 0", "x > 1")  # (occurrence k of an operator may be another site now)
    db = init(second, changed)
    assert ledger.take("scratch", second, db, folder) == {"killed": 0, "timed_out": 0}
    finish(db, {})
    ledger.save_run("scratch", second, "def5678", folder)
    entry = ledger.load("scratch", folder)["modules"]["pkg/mod.py"]
    assert entry["killed"] == {} and entry["tests_at"] == "def5678"


def test_a_survivor_killed_later_keeps_one_verdict(tmp_path):
    folder, tree = tmp_path / "ledger", tmp_path / "a"
    db = init(tree, MODULE)
    finish(db, {})
    ledger.save_run("scratch", tree, "abc1234", folder)
    finish(db, {GT: "killed"})  # (a --survivors run on the same work directory, after a new test)
    ledger.save_run("scratch", tree, "def5678", folder)
    entry = ledger.load("scratch", folder)["modules"]["pkg/mod.py"]
    gt = next(op for op in entry["killed"] if op.endswith(GT))
    assert entry["killed"][gt] == [0] and gt not in entry["survived"]


def test_a_resumed_run_skips_an_earlier_runs_annotations_and_runs_its_other_survivors_again(tmp_path):
    db = init(tmp_path, MODULE)
    finish(db, {GT: "killed"})  # (a run made before annotations were left out: all of them survived)
    runnable_ids = {i.job_id for i in runnable(items(db))}
    run_again(db, tmp_path, widen=False, sample=None)
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        pending = {i.job_id for i in work_db.pending_work_items}
        verdicts = {i.job_id: r for i, r in work_db.completed_work_items}
    gt = {i.job_id for i in items(db) if i.mutations[0].operator_name.endswith(GT)}
    assert pending == runnable_ids - gt  # the survivors, again
    assert all(verdicts[j].worker_outcome == WorkerOutcome.SKIPPED for j in verdicts if j not in gt)
    assert {j for j in verdicts if j not in gt} == {i.job_id for i in items(db)} - runnable_ids
    assert bit_or_lines(db, [i for i in items(db) if i.job_id in pending]) == {4: 1, 7: 1, 8: 1}


def test_a_tally_gives_every_runnable_mutant_its_recorded_verdict_on_the_same_code(tmp_path, monkeypatch):
    """``run.py T --tally``: two shards' runs saved into one ledger give the whole figure; a
    module whose code changed since has no verdicts."""
    import tally

    folder = tmp_path / "ledger"
    halves = []
    for k, name in ((1, "a"), (2, "b")):  # two shards, each in its own work directory
        db = init(tmp_path / name, MODULE)
        run_again(db, tmp_path / name, widen=True, sample=None)  # (the implausible skipped, as a run does)
        assert skip_other_shards(db, tmp_path / name, (k, 2)) > 0
        finish_pending(db, {GT: "killed", "NumberReplacer": "timed_out"})
        halves.append(ledger.save_run("scratch", tmp_path / name, "abc1234", folder)[1])

    def scratch(source):
        def export(tree, rev):
            (tree / "pkg").mkdir()
            (tree / "pkg" / "mod.py").write_text(source)

        def configure(name, tree, config):
            init(tree, source).rename(tree / "unused.sqlite")
            (tree / "cr.toml").rename(config)
        monkeypatch.setattr(tally, "export_tree", export)
        monkeypatch.setattr(tally, "_write_config", configure)
        return tally.tally("scratch", folder=folder)

    counts, survivors = scratch(MODULE)
    total = len(runnable(items(init(tmp_path / "c", MODULE))))
    assert sum(counts.values()) == total and counts[tally.UNDECIDED] == 0
    for verdict in ledger.VERDICTS:  # each mutant counted once, from whichever shard ran it
        assert counts[verdict] == halves[0][verdict] + halves[1][verdict]
    assert len(survivors) == counts["survived"] > 0 and all("pkg/mod.py:" in s for s in survivors)
    counts, _ = scratch(MODULE.replace("x > 0", "x > 1"))
    assert counts[tally.UNDECIDED] == sum(counts.values())


def finish_pending(db: Path, outcome: dict[str, str]) -> None:
    """``finish`` for the mutants still to run only (another shard's stay skipped)."""
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        for item in list(work_db.pending_work_items):
            v = outcome.get(item.mutations[0].operator_name.rsplit("/", 1)[-1], "survived")
            work_db.set_result(item.job_id, WorkResult(
                worker_outcome=WorkerOutcome.NORMAL, output="MUTATION-TIMED-OUT" if v == "timed_out" else "",
                test_outcome=Outcome.SURVIVED if v == "survived" else Outcome.KILLED))
