"""Mutation testing of the modules where a silent bug is dangerous, with cosmic-ray.

    python tests/mutation/run.py safety [--sample N] [--workdir DIR] [--keep]
    python tests/mutation/run.py all --sample 150
    python tests/mutation/run.py protocols         (protocols-mit, protocols-cia402, …)
    python tests/mutation/run.py safety --workdir DIR --resume   (a stopped run, or a sample, to the end)
    python tests/mutation/run.py safety --workdir DIR --survivors   (only the survivors again, after new tests)
    python tests/mutation/run.py guard --workdir DIR --resume --sample 200   (a sample widened to a larger one)
    python tests/mutation/run.py all --count   (mutants per target and one cold run of its tests: no mutant run)

For each target (tests/mutation/targets.py) it copies a committed tree (``git archive``, HEAD or ``--rev``) into a
work directory — cosmic-ray rewrites the source on disk, one mutant at a time, so it must
never run in the tree you work in — plants every mutant of the target's files in turn, runs
the target's tests against the copy, and reports the survivors with their diffs and the
survival rate. Not part of the suite (hours for everything); run it before changing the
tests of these modules, and see docs/mutation/index.md.

Why cosmic-ray and not mutmut: mutmut 3 switches mutants at run time through trampolines and
therefore skips every decorated function — every ``@njit`` kernel, which is where the safety
checks live. cosmic-ray edits the file itself, so numba compiles the mutant like any change.

The operator set is cut to mutants that model plausible slips: comparison boundaries and
negations, + ↔ −, × ↔ ÷, and ↔ or, a dropped or added ``not``, a dropped unary minus,
True ↔ False, numbers ± 1, loops that run zero times, break ↔ continue, a changed exception
type. Swaps such as ``*`` → ``<<`` on floats (a TypeError at once) or ``==`` → ``is`` on
numbers only add run time.

Two passes keep that affordable without changing a verdict (``prepare``, ``mutant_tests.py``,
``selection.py``; docs/mutation/index.md): the fast pass gives a mutant that cannot change compiled
code the unmutated run's kernels and runs only the tests that executed its lines; every
survivor of it runs again with all the target's tests from an empty kernel cache, and only
a survivor of both counts.

``--sample N`` evaluates a fixed pseudo-random subset of N mutants per target, chosen from a
hash of (file, operator, occurrence), so two commits are compared on the same mutants; a
larger N holds every mutant of a smaller one, so a sample can be widened in place.

``--shard K/N`` runs only the K-th of N disjoint parts of those mutants (the same hash modulo
N), so N runs in N work directories share the cores; ``--save-ledger`` of each merges
the whole. A later ``--resume`` without it runs what the other shards left out.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import ledger
from mutant_tests import TOOL_ERROR  # what the test command prints (this script's folder)
from renewal import CR, record_code, renew_moved_mutants
from subsets import in_sample, in_shard, parse_shard, sample_key
from targets import TARGETS
from unevaluated import unevaluated_jobs

ROOT = Path(__file__).resolve().parents[2]
PYTEST = f"{sys.executable} -m pytest -x -q -p no:cacheprovider -p no:randomly -o addopts="
TOOLS = ".mutation"  # in the copy: the test command, what the unmutated run recorded, the warm kernels

GROUPS = {"all": list(TARGETS), "protocols": [t for t in TARGETS if t.startswith("protocols-")]}

_BOUNDARY = {("Lt", "LtE"), ("LtE", "Lt"), ("Gt", "GtE"), ("GtE", "Gt"), ("Eq", "NotEq"), ("NotEq", "Eq"),
             ("Lt", "GtE"), ("GtE", "Lt"), ("Gt", "LtE"), ("LtE", "Gt"), ("Is", "IsNot"), ("IsNot", "Is")}
_ARITHMETIC = {("Add", "Sub"), ("Sub", "Add"), ("Mul", "Div"), ("Div", "Mul"), ("FloorDiv", "Div"),
               ("Div", "FloorDiv"), ("BitOr", "BitAnd"), ("BitAnd", "BitOr"), ("LShift", "RShift"),
               ("RShift", "LShift"), ("Mod", "FloorDiv")}
_PLAIN = {"AddNot", "ReplaceAndWithOr", "ReplaceOrWithAnd", "ReplaceTrueWithFalse", "ReplaceFalseWithTrue",
          "ZeroIterationForLoop", "ReplaceBreakWithContinue", "ReplaceContinueWithBreak", "ExceptionReplacer",
          "NumberReplacer", "ReplaceUnaryOperator_USub_UAdd", "ReplaceUnaryOperator_Delete_USub",
          "ReplaceUnaryOperator_Delete_Not"}


def plausible(operator: str) -> bool:
    """Whether a cosmic-ray operator name (``core/ReplaceComparisonOperator_Lt_LtE``) is in the set."""
    name = operator.rsplit("/", 1)[-1]
    if name in _PLAIN:
        return True
    m = re.fullmatch(r"Replace(Comparison|Binary)Operator_(\w+?)_(\w+)", name)
    if m is None:
        return False
    pair = (m.group(2), m.group(3))
    return pair in (_BOUNDARY if m.group(1) == "Comparison" else _ARITHMETIC)


def runnable(items) -> list:
    """The work items worth running: every mutation plausible, and not inside an annotation
    Python never evaluates (tests/mutation/unevaluated.py: equivalent by construction)."""
    items = [i for i in items if all(plausible(m.operator_name) for m in i.mutations)]
    idle = unevaluated_jobs(items)
    return [i for i in items if i.job_id not in idle]


def skip_other_shards(db: Path, tree: Path, shard: tuple[int, int] | None) -> int:
    """Mark every mutant still to run that is not in ``shard`` as skipped (a resume without a
    shard runs it); returns how many run."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult

    with use_db(str(db), WorkDB.Mode.open) as work_db:
        pending = list(work_db.pending_work_items)
        other = [i.job_id for i in pending if not in_shard(sample_key(i, tree), shard)]
        work_db.set_multiple_results(other, WorkResult(output="another shard's",
                                                       worker_outcome=WorkerOutcome.SKIPPED))
    return len(pending) - len(other)


def export_tree(dest: Path, rev: str) -> None:
    archive = subprocess.run(["git", "archive", rev], cwd=ROOT, capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)


def run_target(name: str, workdir: Path, sample: int | None, rev: str = "HEAD", count_only: bool = False,
               from_ledger: bool = False, shard: tuple[int, int] | None = None) -> dict:
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult

    tree = workdir / name
    tree.mkdir(parents=True, exist_ok=True)
    export_tree(tree, rev)
    _record_rev(tree, rev)
    config, db = tree / "cosmic-ray.toml", tree / "session.sqlite"
    tests = _write_config(name, tree, config)
    env = _env(tree)
    subprocess.run([*CR, "init", config, db], cwd=tree, env=env, check=True, capture_output=True)
    record_code(db)
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        items = list(work_db.pending_work_items)
        keep = runnable(items)
        chosen = {i.job_id for i in keep
                  if in_sample(sample_key(i, tree), sample, len(keep)) and in_shard(sample_key(i, tree), shard)}
        skipped = [i.job_id for i in items if i.job_id not in chosen]
        work_db.set_multiple_results(skipped, WorkResult(output="not in the plausible set or the sample",
                                                         worker_outcome=WorkerOutcome.SKIPPED))
    print(f"{name}: {len(items)} mutants, {len(keep)} plausible, {'would run' if count_only else 'running'} "
          f"{len(chosen)}{'' if shard is None else ' (shard %d/%d)' % shard}", flush=True)
    if from_ledger:
        print(f"{name}: from the ledger, {ledger.take(name, tree, db)}", flush=True)
    if count_only:
        started = time.monotonic()
        baseline = subprocess.run(PYTEST.split() + tests.split(), cwd=tree, env=env, capture_output=True, text=True)
        seconds = time.monotonic() - started
        shutil.rmtree(tree / ".numba", ignore_errors=True)
        if baseline.returncode != 0:
            raise SystemExit(f"{name}: the tests fail without any mutant:\n{baseline.stdout[-3000:]}")
        print(f"{name}: the tests take {seconds:.0f} s from a cold kernel cache; {len(chosen)} mutants ≈ "
              f"{len(chosen) * seconds / 3600:.1f} h (a killed mutant stops at its first failure: less)", flush=True)
        return {"target": name, "mutants": 0, "killed": 0, "timeouts_or_crashes": 0, "survived": 0,
                "survival_rate": None, "plausible": len(keep), "seconds": round(seconds, 1)}
    prepare(name, tree, tests)
    _exec(config, db, tree)
    return report(name, tree, db)


def target_files(name: str, tree: Path) -> list[str]:
    """The target's source files, relative to ``tree``."""
    files = []
    for p in TARGETS[name][0]:
        path = tree / p
        files += [str(f.relative_to(tree)) for f in sorted(path.rglob("*.py"))] if path.is_dir() else [p]
    return files


def prepare(name: str, tree: Path, tests: str) -> None:
    """Run the target's tests once on the unmutated copy, under coverage with one context per
    test, and keep in ``<tree>/.mutation`` what the test command needs: the pristine files and
    their hashes, the kernel closure, which tests execute each line, and the compiled kernels."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from selection import cache_owners, fastest_first, kernel_closure, kernel_dependents, lines_to_tests, tree_cache_key

    tools = tree / TOOLS
    shutil.rmtree(tools, ignore_errors=True)
    (tools / "warm").mkdir(parents=True)
    for tool in ("mutant_tests.py", "selection.py"):
        shutil.copy2(Path(__file__).resolve().parent / tool, tools / tool)
    files = target_files(name, tree)
    for rel in files:
        (tools / "pristine" / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(tree / rel, tools / "pristine" / rel)
    (tools / "coveragerc").write_text("[run]\ninclude =\n" + "".join(f"    {tree / rel}\n" for rel in files))
    env = {**_env(tree), "COVERAGE_FILE": str(tools / "coverage")}
    collected = subprocess.run(PYTEST.split() + ["--collect-only"] + tests.split(), cwd=tree, env=env,
                               capture_output=True, text=True)
    order = [line for line in collected.stdout.splitlines() if "::" in line]
    shutil.rmtree(tree / ".numba", ignore_errors=True)
    started = time.monotonic()
    baseline = subprocess.run(PYTEST.split() + [f"--cov-config={tools / 'coveragerc'}", "--cov", "--cov-context=test",
                                                "--cov-report=", "--durations=0", "--durations-min=0"] + tests.split(),
                              cwd=tree, env=env, capture_output=True, text=True)
    baseline_s = time.monotonic() - started
    if baseline.returncode != 0 or not order:
        raise SystemExit(f"{name}: the tests fail without any mutant:\n{baseline.stdout[-3000:]}")
    kernels = list((tree / ".numba").glob("rtctl-kernels-*"))
    expected = "rtctl-kernels-" + tree_cache_key(tree, env)
    warm = None
    if [k.name for k in kernels] == [expected]:
        shutil.move(kernels[0], tools / "warm" / expected)
        warm = expected
    else:
        print(f"{name}: the unmutated run left {[k.name for k in kernels]}, not {expected}: no warm kernels",
              flush=True)
    shutil.rmtree(tree / ".numba", ignore_errors=True)
    order = fastest_first(order, baseline.stdout)
    covered = lines_to_tests(tools / "coverage", tree, files, order)
    closure = kernel_closure(tree)
    dependents = kernel_dependents(tree)
    state = {"tests": tests, "seconds": round(baseline_s, 1),
             "files": {rel: hashlib.sha256((tree / rel).read_bytes()).hexdigest() for rel in files},
             "closure": sorted(set(files) & closure), "warm": warm, "order": order, "covered": covered,
             "dependents": {rel: dependents[rel] for rel in set(files) & closure},
             "owners": cache_owners(tools / "warm" / warm, tree) if warm else {}}
    (tools / "baseline.json").write_text(json.dumps(state))
    print(f"{name}: unmutated run under coverage {time.monotonic() - started:.0f} s, {len(order)} tests; "
          f"{len(state['closure'])} of {len(files)} files in the kernel closure (an empty cache for their mutants)",
          flush=True)


def existing_tests(words: list[str], tree: Path) -> list[str]:
    """pytest's arguments without the test files or folders that are not in ``tree`` (one that
    moved since the run started); options and their values stay."""
    kept, value_of = [], False
    for word in words:
        if value_of or word.startswith("-") or (tree / word.split("::")[0]).exists():
            kept.append(word)
        value_of = word in ("--deselect", "-k", "-m", "--ignore")
    return kept


def _write_config(name: str, tree: Path, config: Path) -> str:
    """cosmic-ray's configuration for ``name`` in ``tree``, with the target's tests as they are
    now (a resumed run picks up new test files); returns the tests."""
    paths, tests, timeout = TARGETS[name]
    tests = " ".join(existing_tests(tests.split(), tree))
    modules = ", ".join(json.dumps(str(tree / p)) for p in paths)
    config.write_text(f'[cosmic-ray]\nmodule-path = [{modules}]\ntimeout = {float(timeout)}\nexcluded-modules = []\n'
                      f'test-command = "{sys.executable} {tree / TOOLS / "mutant_tests.py"}"\n\n'
                      '[cosmic-ray.distributor]\nname = "local"\n')
    return tests


def resume_target(name: str, workdir: Path, rev: str = "HEAD", widen: bool = True, sample: int | None = None,
                  from_ledger: bool = False, shard: tuple[int, int] | None = None) -> dict:
    """Continue the run of ``name`` in ``workdir`` (one that was stopped, or a sample to widen
    to every mutant, or to a larger ``sample``): the tree is exported again at ``rev`` — the
    tests as they are now, and no mutant left planted by a stopped run — and every plausible
    mutant not yet killed is run: those never run and the survivors, again. ``widen=False``
    keeps a sample as it is: only the survivors (and what a stopped run left unfinished) run again."""
    from cosmic_ray.work_db import WorkDB, use_db

    tree = workdir / name
    config, db = tree / "cosmic-ray.toml", tree / "session.sqlite"
    if not db.exists():
        raise SystemExit(f"{name}: no run to resume in {tree}")
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        elsewhere = {m.module_path for item in work_db.work_items for m in item.mutations
                     if not m.module_path.is_relative_to(tree)}
    if elsewhere:  # (a moved work directory: cosmic-ray would plant the mutants in the old copy)
        raise SystemExit(f"{name}: the run's mutants are in files outside {tree}, e.g. {min(elsewhere)}")
    export_tree(tree, rev)
    tests = _write_config(name, tree, config)
    _record_rev(tree, rev)
    for module, n in renew_moved_mutants(config, db, tree, _env(tree), plausible).items():
        print(f"{name}: {module} changed since its mutants were made: its {n} mutants are made again", flush=True)
    run_again(db, tree, widen, sample)
    if from_ledger:
        print(f"{name}: from the ledger, {ledger.take(name, tree, db)}", flush=True)
    pending = skip_other_shards(db, tree, shard)  # a stopped run's unfinished ones too
    print(f"{name}: resuming in {tree}, {pending} mutants to run"
          f"{'' if shard is None else ' (shard %d/%d)' % shard}", flush=True)
    prepare(name, tree, tests)
    _exec(config, db, tree)
    return report(name, tree, db)


def run_again(db: Path, tree: Path, widen: bool, sample: int | None) -> None:
    """What a resumed run runs: every runnable mutant without a verdict — the survivors, a
    stopped run's unfinished ones, and with ``widen`` those the sample left out — and none that
    is not runnable (an earlier run's annotations: skipped now)."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome, WorkResult

    with use_db(str(db), WorkDB.Mode.open) as work_db:
        items = list(work_db.work_items)
        keep = {i.job_id for i in runnable(items)}
        idle = [i.job_id for i in items if i.job_id not in keep]
        again = [item.job_id for item, result in work_db.completed_work_items
                 if item.job_id in keep
                 and ((widen and result.worker_outcome == WorkerOutcome.SKIPPED
                       and in_sample(sample_key(item, tree), sample, len(keep)))
                      or result.test_outcome == TestOutcome.SURVIVED)]
    with sqlite3.connect(db) as con:
        con.executemany("DELETE FROM work_results WHERE job_id = ?", [(j,) for j in again + idle])
        con.execute("DELETE FROM work_results WHERE output LIKE ?", (f"%{TOOL_ERROR}%",))  # (a stopped one: no verdict)
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        work_db.set_multiple_results(idle, WorkResult(output="not in the plausible set",
                                                      worker_outcome=WorkerOutcome.SKIPPED))


def _env(tree: Path) -> dict:
    """The tests' environment: the copy on the path, its compiled kernels under ``.numba``.
    rtctl keeps them in ``.numba/rtctl-kernels-<hash of the sources>`` (rtctl.kernel_cache),
    so each mutant gets a cache of its own — numba alone would reuse a caller compiled against
    an earlier mutant's (or the original) callee in another file — which the next mutant's
    test command removes before it starts. Every index in compiled code is checked
    (``NUMBA_BOUNDSCHECK``): a mutant that reads past an array is a kill even where the
    memory it reads happens not to change a result (the unmutated run proves the tests pass
    so, and every kernel of a run is compiled under it: the warm ones too)."""
    return {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(tree / ".numba"),
            "NUMBA_BOUNDSCHECK": "1"}


def _exec(config: Path, db: Path, tree: Path) -> None:
    """Run the pending mutants in the fast pass, then every survivor again in the full pass
    (the target's full tests, an empty kernel cache): only a survivor of both counts."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import TestOutcome

    try:
        subprocess.run([*CR, "exec", config, db], cwd=tree, env={**_env(tree), "MUTATION_MODE": "fast"}, check=True)
        _stop_on_tool_errors(db)
        with use_db(str(db), WorkDB.Mode.open) as work_db:
            again = [item.job_id for item, result in work_db.completed_work_items
                     if result.test_outcome == TestOutcome.SURVIVED]
        with sqlite3.connect(db) as con:
            con.executemany("DELETE FROM work_results WHERE job_id = ?", [(j,) for j in again])
        print(f"{tree.name}: {len(again)} survivors of the fast pass, again with all tests and no cached kernels",
              flush=True)
        subprocess.run([*CR, "exec", config, db], cwd=tree, env={**_env(tree), "MUTATION_MODE": "full"}, check=True)
        _stop_on_tool_errors(db)
    finally:
        shutil.rmtree(tree / ".numba", ignore_errors=True)


def _stop_on_tool_errors(db: Path) -> None:
    """Stop if the test command itself failed on some mutants (their results dropped: a resume runs them)."""
    with sqlite3.connect(db) as con:
        bad = [r[0] for r in con.execute("SELECT job_id FROM work_results WHERE output LIKE ?", (f"%{TOOL_ERROR}%",))]
        output = con.execute("SELECT output FROM work_results WHERE output LIKE ? LIMIT 1",
                             (f"%{TOOL_ERROR}%",)).fetchone()
        con.executemany("DELETE FROM work_results WHERE job_id = ?", [(j,) for j in bad])
    if bad:
        raise SystemExit(f"the test command failed on {len(bad)} mutants (not counted; --resume runs them):\n{output[0]}")


def report(name: str, tree: Path, db: Path) -> dict:
    from cosmic_ray.work_db import WorkDB, use_db

    survivors, killed, timeouts = [], 0, 0
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        for item, result in work_db.completed_work_items:
            found = ledger.verdict(result)
            if found == "survived":
                m = item.mutations[0]
                survivors.append({"file": str(Path(m.module_path).relative_to(tree)), "line": m.start_pos[0],
                                  "operator": m.operator_name.rsplit("/", 1)[-1], "diff": result.diff})
            elif found == "timed_out":
                timeouts += 1
            elif found == "killed":
                killed += 1
    total = len(survivors) + killed + timeouts
    summary = {"target": name, "mutants": total, "killed": killed, "timeouts_or_crashes": timeouts,
               "survived": len(survivors), "survival_rate": round(len(survivors) / total, 4) if total else None,
               "survivors": sorted(survivors, key=lambda s: (s["file"], s["line"]))}
    (tree / "report.json").write_text(json.dumps(summary, indent=1))
    print(f"{name}: {len(survivors)} of {total} survived ({100 * (summary['survival_rate'] or 0):.1f} %); "
          f"report: {tree / 'report.json'}", flush=True)
    return summary


def _record_rev(tree: Path, rev: str) -> None:
    """Which commit the copy's tests are (the ledger says what its verdicts were measured with)."""
    commit = subprocess.run(["git", "rev-parse", "--short", rev], cwd=ROOT, capture_output=True, text=True, check=True)
    (tree / "rev").write_text(commit.stdout.strip())


def save_ledger(name: str, workdir: Path) -> None:
    """Merge the verdicts the run in ``workdir`` has reached so far into the target's ledger."""
    tree = workdir / name
    if not (tree / "session.sqlite").exists():
        raise SystemExit(f"{name}: no run in {tree}")
    rev = (tree / "rev").read_text() if (tree / "rev").is_file() else ledger.head(ROOT)
    path, counts = ledger.save_run(name, tree, rev)
    print(f"{name}: {counts} from {tree} merged into {path.relative_to(ROOT)}", flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("target", choices=[*TARGETS, *GROUPS])
    p.add_argument("--sample", type=int, default=None, help="evaluate this many mutants per target (default: all)")
    p.add_argument("--workdir", type=Path, default=None, help="where the copies go (default: a new temp dir)")
    p.add_argument("--rev", default="HEAD", help="the commit to test (default: HEAD)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --workdir: what was not run, and the survivors again, at --rev")
    p.add_argument("--survivors", action="store_true",
                   help="run the survivors of the run in --workdir again at --rev (after new tests), keeping its sample")
    p.add_argument("--count", action="store_true",
                   help="only count the mutants and time one run of the tests from a cold kernel cache")
    p.add_argument("--ledger", action="store_true",
                   help="take the kills and time-outs of tests/mutation/ledger/<target>.json on unchanged code")
    p.add_argument("--shard", type=parse_shard, default=None, metavar="K/N",
                   help="run only part K of N of the mutants (N runs in N work directories share the cores)")
    p.add_argument("--tally", action="store_true",
                   help="print the target's figure at --rev from the ledger (every mutant's recorded verdict), and stop")
    p.add_argument("--save-ledger", action="store_true",
                   help="merge the verdicts of the run in --workdir so far into the ledger, and stop")
    args = p.parse_args(argv)
    if (args.resume or args.survivors or args.save_ledger) and args.workdir is None:
        p.error("--resume, --survivors and --save-ledger need the run's --workdir")
    if args.survivors and args.sample is not None:
        p.error("--survivors keeps the run's own sample (--resume --sample N widens it to N)")
    names = GROUPS.get(args.target, [args.target])
    if args.tally:
        from tally import describe, tally

        for n in names:
            counts, survivors = tally(n, args.rev)
            print("\n".join([*survivors, describe(n, ledger.head(ROOT) if args.rev == "HEAD" else args.rev, counts)]))
        return 0
    workdir = (args.workdir or Path(tempfile.mkdtemp(prefix="rtctl-mutation-"))).resolve()
    if args.save_ledger:
        for n in names:
            save_ledger(n, workdir)
        return 0
    results = [resume_target(n, workdir, args.rev, widen=not args.survivors, sample=args.sample,
                             from_ledger=args.ledger, shard=args.shard)
               if args.resume or args.survivors
               else run_target(n, workdir, args.sample, args.rev, count_only=args.count, from_ledger=args.ledger,
                               shard=args.shard)
               for n in names]
    print(f"\n{'target':<18} {'mutants':>8} {'killed':>7} {'t/o':>5} {'survived':>9} {'rate':>7}")
    for r in results:
        rate = "" if r["survival_rate"] is None else f"{100 * r['survival_rate']:.1f} %"
        print(f"{r['target']:<18} {r['mutants']:>8} {r['killed']:>7} {r['timeouts_or_crashes']:>5} "
              f"{r['survived']:>9} {rate:>7}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
