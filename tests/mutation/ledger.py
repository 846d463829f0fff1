"""Verdicts that outlive a run's work directory (tests/mutation/run.py ``--save-ledger``, ``--ledger``).

A full run of a large target takes longer than one sitting, and its work directory lives on
one machine. The ledger (``tests/mutation/ledger/<target>.json``, committed) keeps what a run
has decided, module by module, keyed as :mod:`renewal` keys a resumed run: the hash of the
module's code without docstrings, and cosmic-ray's (operator, occurrence) — the same code
gives the same mutants in the same order. A new run with ``--ledger`` takes the kills and
time-outs of every module whose code is still the same and runs the rest; survivors always
run again (new tests may catch them). Like ``--resume``, it trusts a kill made with the
tests of that day: tests are added, not weakened.
"""
from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

from mutant_tests import TIMED_OUT, TOOL_ERROR
from renewal import code_hash

FOLDER = Path(__file__).resolve().parent / "ledger"
VERDICTS = ("killed", "timed_out", "survived")


def load(target: str, folder: Path = FOLDER) -> dict:
    path = folder / f"{target}.json"
    return json.loads(path.read_text()) if path.is_file() else {"target": target, "modules": {}}


def save(target: str, verdicts: dict[str, dict], codes: dict[str, str], rev: str, folder: Path = FOLDER) -> Path:
    """Merge the verdicts of a run — {module: {verdict: {operator: [occurrence, …]}}}, modules
    relative to the tree, ``codes`` their code hashes — into the ledger: a module the run has
    verdicts for replaces its entry when its code changed, else adds to it."""
    ledger = load(target, folder)
    for module, found in sorted(verdicts.items()):
        entry = ledger["modules"].get(module)
        if entry is None or entry["code"] != codes[module]:
            entry = {"code": codes[module], **{v: {} for v in VERDICTS}}
        for verdict, by_operator in found.items():
            for operator, occurrences in by_operator.items():
                for other in VERDICTS:  # (a survivor later killed: one verdict per mutant)
                    if other != verdict and operator in entry[other]:
                        entry[other][operator] = [o for o in entry[other][operator] if o not in occurrences]
                entry[verdict][operator] = sorted(set(entry[verdict].get(operator, [])) | set(occurrences))
        for verdict in VERDICTS:
            entry[verdict] = {op: occ for op, occ in sorted(entry[verdict].items()) if occ}
        entry["tests_at"] = rev
        ledger["modules"][module] = entry
    path = folder / f"{target}.json"
    folder.mkdir(exist_ok=True)
    text = json.dumps(ledger, indent=1, sort_keys=True)
    text = re.sub(r"\[[\d,\s]*\]", lambda m: json.dumps(json.loads(m.group(0))), text)  # (occurrences on one line)
    path.write_text(text + "\n")
    return path


def recorded(target: str, tree: Path, folder: Path = FOLDER) -> dict[tuple[str, str, int], str]:
    """(module, operator, occurrence) → "killed", "timed_out" or "survived", for every module of
    the ledger whose code in ``tree`` is what its verdicts were measured on."""
    known = {}
    for module, entry in load(target, folder)["modules"].items():
        if code_hash(tree / module) != entry["code"]:
            continue
        for verdict in VERDICTS:
            for operator, occurrences in entry[verdict].items():
                known.update({(module, operator, o): verdict for o in occurrences})
    return known


def decided(target: str, tree: Path, folder: Path = FOLDER) -> dict[tuple[str, str, int], str]:
    """What a new run takes from the ledger: its kills and time-outs on unchanged code."""
    return {k: v for k, v in recorded(target, tree, folder).items() if v != "survived"}


def verdict(result) -> str | None:
    """A cosmic-ray result as "killed", "timed_out" or "survived"; None for a mutant not run
    (skipped, or stopped by the tool: no verdict)."""
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome

    if result.worker_outcome == WorkerOutcome.SKIPPED or TOOL_ERROR in (result.output or ""):
        return None
    if result.test_outcome == TestOutcome.SURVIVED:
        return "survived"
    if (result.worker_outcome == WorkerOutcome.ABNORMAL or result.output == "timeout"  # cosmic-ray's word
            or TIMED_OUT in (result.output or "")):  # the test command's own limit
        return "timed_out"
    return "killed"


def save_run(target: str, tree: Path, rev: str, folder: Path = FOLDER) -> tuple[Path, dict[str, int]]:
    """Merge the verdicts of the run in ``tree`` so far into the ledger; the ledger's path and
    how many of each verdict the run gave."""
    from cosmic_ray.work_db import WorkDB, use_db

    found: dict[str, dict] = {}
    with use_db(str(tree / "session.sqlite"), WorkDB.Mode.open) as work_db:
        for item, result in work_db.completed_work_items:
            v, m = verdict(result), item.mutations[0]
            if v is not None:
                module = str(Path(m.module_path).relative_to(tree))
                found.setdefault(module, {}).setdefault(v, {}).setdefault(m.operator_name, []).append(m.occurrence)
    made_from = json.loads((tree / "mutants_made_from.json").read_text())  # (renewal.record_code)
    codes = {str(Path(m).relative_to(tree)): h for m, h in made_from.items()}
    counts = {v: sum(len(o) for f in found.values() for o in f.get(v, {}).values()) for v in VERDICTS}
    return save(target, found, codes, rev, folder), counts


def take(target: str, tree: Path, db: Path, folder: Path = FOLDER) -> dict[str, int]:
    """Give every pending mutant of the run in ``tree`` that the ledger has killed or timed out
    on the same code that verdict; how many of each."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome, WorkResult

    known = decided(target, tree, folder)
    taken: dict[str, list] = {"killed": [], "timed_out": []}
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        for item in work_db.pending_work_items:
            m = item.mutations[0]
            v = known.get((str(Path(m.module_path).relative_to(tree)), m.operator_name, m.occurrence))
            if v is not None:
                taken[v].append(item.job_id)
        work_db.set_multiple_results(taken["killed"], WorkResult(
            output="killed (the ledger)", worker_outcome=WorkerOutcome.NORMAL, test_outcome=TestOutcome.KILLED))
        work_db.set_multiple_results(taken["timed_out"], WorkResult(
            output=f"{TIMED_OUT} (the ledger)", worker_outcome=WorkerOutcome.NORMAL, test_outcome=TestOutcome.KILLED))
    return {v: len(jobs) for v, jobs in taken.items()}


def head(cwd: Path) -> str:
    return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=cwd, capture_output=True, text=True,
                          check=True).stdout.strip()
