"""A resumed mutation run's mutants made again where the code they mutate changed
(tests/mutation/run.py).

cosmic-ray applies "occurrence k of operator X". After an edit that moves a module's mutation
sites, each recorded mutant of that module names another site, or none: its result describes
code that no longer exists. So a resumed run compares the sites it recorded with a fresh
``cosmic-ray init``. A module whose sites stayed keeps its results; so does one whose sites
moved only because its docstrings or comments changed: the run records, next to its
database, a hash of each module's code (its AST without docstrings) when its mutants were
made (:func:`record_code`); where that hash is the same now, its sites are moved to where they
are. Every other module whose sites moved gets its mutants made again, as never run.
"""
from __future__ import annotations

import ast
import hashlib
import json
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Callable

CR = [sys.executable, "-m", "cosmic_ray.cli"]
_DOCUMENTED = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)


def _sites(db: Path) -> dict[str, list]:
    """module → sorted ((operator, occurrence, start row, start col, end row, end col), job id)."""
    with sqlite3.connect(db) as con:
        rows = con.execute("SELECT module_path, operator_name, occurrence, start_pos_row, start_pos_col, end_pos_row, "
                           "end_pos_col, job_id FROM mutation_specs").fetchall()
    sites: dict[str, list] = {}
    for module, *site, job in rows:
        sites.setdefault(module, []).append((tuple(site), job))
    return {m: sorted(v) for m, v in sites.items()}


def code_without_docstrings(source: str) -> str | None:
    """The module's AST with every docstring emptied, as text (positions left out); None if it
    does not parse."""
    try:
        module = ast.parse(source)
    except SyntaxError:
        return None
    for node in ast.walk(module):
        if isinstance(node, _DOCUMENTED) and node.body and isinstance(node.body[0], ast.Expr) \
                and isinstance(node.body[0].value, ast.Constant) and isinstance(node.body[0].value.value, str):
            node.body[0].value.value = ""
    return ast.dump(module)


def code_hash(path: Path) -> str | None:
    code = code_without_docstrings(path.read_text()) if path.is_file() else None
    return None if code is None else hashlib.sha256(code.encode()).hexdigest()


def _recorded(db: Path) -> Path:
    return db.with_name("mutants_made_from.json")


def record_code(db: Path) -> None:
    """Record the code each module of the run's mutants now is (after ``init`` or a renewal)."""
    _recorded(db).write_text(json.dumps({m: code_hash(Path(m)) for m in _sites(db)}, indent=0))


def renew_moved_mutants(config: Path, db: Path, tree: Path, env: dict, plausible: Callable[[str], bool]) -> dict[str, int]:
    """Make the mutants of every module whose sites moved and whose code changed since the run
    made them again from ``tree`` as it is, as never run; {module: its new count of plausible
    mutants}. See the module doc."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult

    fresh = db.with_name("fresh.sqlite")
    fresh.unlink(missing_ok=True)
    subprocess.run([*CR, "init", config, fresh], cwd=tree, env=env, check=True, capture_output=True)
    old, new = _sites(db), _sites(fresh)
    moved = sorted(m for m in new.keys() | old.keys() if [s for s, _ in old.get(m, [])] != [s for s, _ in new.get(m, [])])
    made_from = json.loads(_recorded(db).read_text()) if _recorded(db).is_file() else {}  # (none: an older run)
    shifted = [m for m in moved if made_from.get(m) is not None and made_from[m] == code_hash(Path(m))]
    with sqlite3.connect(db) as con:
        for m in shifted:  # (the same mutants in the same order: occurrence k of X is the same change)
            now = {site[:2]: site[2:] for site, _ in new[m]}
            con.executemany("UPDATE mutation_specs SET start_pos_row = ?, start_pos_col = ?, end_pos_row = ?, "
                            "end_pos_col = ? WHERE job_id = ?", [(*now[site[:2]], job) for site, job in old[m]])
    moved = [m for m in moved if m not in shifted]
    with use_db(str(fresh), WorkDB.Mode.open) as fresh_db:
        made = [item for item in fresh_db.work_items if str(item.mutations[0].module_path) in moved]
    with sqlite3.connect(db) as con:
        stale = [(job,) for m in moved for _, job in old.get(m, [])]
        for table in ("work_results", "mutation_specs", "work_items"):
            con.executemany(f"DELETE FROM {table} WHERE job_id = ?", stale)
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        work_db.add_work_items(made)
        skipped = [i.job_id for i in made if not all(plausible(m.operator_name) for m in i.mutations)]
        work_db.set_multiple_results(skipped, WorkResult(output="not in the plausible set",
                                                         worker_outcome=WorkerOutcome.SKIPPED))
    fresh.unlink()
    record_code(db)
    return {str(Path(m).relative_to(tree)): sum(1 for i in made if str(i.mutations[0].module_path) == m
                                                 and i.job_id not in skipped) for m in moved}
