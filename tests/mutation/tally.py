"""A target's figure from its ledger (``run.py T --tally``): every runnable mutant of the
code at a commit, with the verdict the ledger holds for it — whichever runs, shards or
machines gave it. A mutant without one (never run, or its module changed since) is counted
apart, so a partial figure says so."""
from __future__ import annotations

import subprocess
import tempfile
from collections import Counter
from pathlib import Path

import ledger
from renewal import CR
from run import _env, _write_config, export_tree, runnable

UNDECIDED = "no verdict"


def tally(name: str, rev: str = "HEAD", folder: Path = ledger.FOLDER) -> tuple[Counter, list[str]]:
    """(count per verdict, the survivors as ``module:line operator #occurrence``) of target
    ``name`` at ``rev``."""
    from cosmic_ray.work_db import WorkDB, use_db

    with tempfile.TemporaryDirectory(prefix="rtctl-tally-") as tmp:
        tree = Path(tmp) / name
        tree.mkdir()
        export_tree(tree, rev)
        config, db = tree / "cosmic-ray.toml", tree / "session.sqlite"
        _write_config(name, tree, config)
        subprocess.run([*CR, "init", config, db], cwd=tree, env=_env(tree), check=True, capture_output=True)
        with use_db(str(db), WorkDB.Mode.open) as work_db:
            items = runnable(list(work_db.pending_work_items))
        known = ledger.recorded(name, tree, folder)
        counts, survivors = Counter(), []
        for item in items:
            m = item.mutations[0]
            module = str(Path(m.module_path).relative_to(tree))
            verdict = known.get((module, m.operator_name, m.occurrence), UNDECIDED)
            counts[verdict] += 1
            if verdict == "survived":
                survivors.append(f"{module}:{m.start_pos[0]} {m.operator_name.rsplit('/', 1)[-1]} #{m.occurrence}")
    return counts, sorted(survivors)


def describe(name: str, rev: str, counts: Counter) -> str:
    decided = sum(counts[v] for v in ledger.VERDICTS)
    rate = f"{100 * counts['survived'] / decided:.1f} %" if decided else "—"
    return (f"{name} at {rev}: {sum(counts.values())} mutants — {counts['killed']} killed, "
            f"{counts['timed_out']} timed out, {counts['survived']} survived ({rate} of those decided), "
            f"{counts[UNDECIDED]} {UNDECIDED}")
