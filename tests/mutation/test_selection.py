"""The mutation runner's shortcuts (tests/mutation/selection.py, mutant_tests.py) on small fixtures:
which files may change compiled code, which tests a mutated line selects, and the hard-linked
warm kernels. (This runs no mutant: cosmic-ray starts only from tests/mutation/run.py.)"""
from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from mutant_tests import TIMED_OUT, Stopped, link_warm, reusable, run_tests
from selection import (cache_owners, changed_lines, fastest_first, kernel_closure, kernel_dependents, line_kinds,
                       lines_to_tests, select_tests)


def write(root: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(textwrap.dedent(text))


PACKAGE = {
    "rtctl/__init__.py": "",
    "rtctl/compiled.py": "from numba import njit\ndef kernel(fn):\n    return njit(cache=True)(fn)\n",
    "rtctl/units.py": "SCALE = 2\n",
    "rtctl/consts.py": "from rtctl.units import SCALE\nLIMIT = 3 * SCALE\n",
    "rtctl/sub/__init__.py": "from rtctl.sub.glue import run\n",  # imported on the way to kern: no kernel reads it
    "rtctl/sub/kern.py": """\
        from ..compiled import kernel
        from ..consts import LIMIT
        @kernel
        def over(x):
            return x > LIMIT
        """,
    "rtctl/sub/glue.py": "from rtctl.sub.kern import over\ndef run(x):\n    return over(x)\n",  # calls a kernel only
    "rtctl/sub/patcher.py": "import rtctl.units as u\nimport rtctl.report\ndef louder():\n    u.SCALE = 3\n",
    "rtctl/report.py": "TITLE = 'x'\n",  # imported by a file that rebinds another module's global
    "rtctl/cli.py": "import numba\nfrom rtctl.sub import glue\n",  # numba imported, nothing compiled
    "drivers/__init__.py": "",
    "drivers/fast.py": "from numba import njit\nfrom drivers import table\ndef g(a):\n    return table.K * a\n"
                       "g_fast = njit(g)\n",
    "drivers/table.py": "K = 4\n",
    "drivers/slow.py": "from drivers.fast import g_fast\n",
}


def test_the_kernel_closure_is_what_kernels_define_or_read(tmp_path):
    write(tmp_path, PACKAGE)
    assert kernel_closure(tmp_path) == {
        "rtctl/sub/kern.py", "rtctl/compiled.py", "rtctl/consts.py", "rtctl/units.py",  # a kernel and what it reads
        "rtctl/sub/patcher.py", "rtctl/report.py",  # rebinds a module's global (and what it imports)
        "rtctl/__init__.py",  # `import rtctl.report` binds the name rtctl
        "drivers/fast.py", "drivers/table.py",  # njit(g) called, not as a decorator
    }  # not: glue, cli, slow (they call kernels), the packages' __init__ files


SOURCE = '''\
LIMIT = 3


@kernel
def over(x):
    return x > LIMIT


def clamp(x,
          lo=-1):
    y = max(lo,
            x)
    if y > LIMIT:
        return LIMIT
    return y


class Box:
    size = 2

    def area(self):
        return self.size * self.size
'''


def test_a_files_dependents_are_the_kernel_files_that_reach_it_and_all_past_a_rebinding_one(tmp_path):
    write(tmp_path, PACKAGE)
    assert kernel_dependents(tmp_path) == {
        "rtctl/sub/kern.py": ["rtctl/sub/kern.py"],  # its own kernel
        "rtctl/compiled.py": ["rtctl/sub/kern.py"], "rtctl/consts.py": ["rtctl/sub/kern.py"],  # read by it
        "drivers/fast.py": ["drivers/fast.py"], "drivers/table.py": ["drivers/fast.py"],
        "rtctl/units.py": None,  # patcher.py rebinds it: any kernel may change
        "rtctl/sub/patcher.py": None, "rtctl/report.py": None, "rtctl/__init__.py": None,
    }


CALLS = {  # caller.py's kernel calls callee.py's; other.py's kernel stands alone
    "rtctl/__init__.py": "",
    "rtctl/callee.py": "from numba import njit\nOFFSET = 1.0\n@njit(cache=True)\ndef shifted(x):\n"
                       "    return x + OFFSET\n",
    "rtctl/caller.py": "from numba import njit\nfrom rtctl.callee import shifted\n@njit(cache=True)\n"
                       "def scaled(x):\n    return 10.0 * shifted(x)\n",
    "rtctl/sub/__init__.py": "",
    "rtctl/sub/other.py": "from numba import njit\n@njit(cache=True)\ndef doubled(x):\n    return 2.0 * x\n",
}
RUN_CALLS = """
from rtctl.caller import scaled
from rtctl.sub.other import doubled
print(scaled(1.0), doubled(1.0), scaled.stats.cache_hits.total(), doubled.stats.cache_hits.total())
"""


@pytest.mark.parametrize(("mutated", "old", "new", "expected"), [
    ("rtctl/callee.py", "OFFSET = 1.0", "OFFSET = 2.0", ["30.0", "2.0", "0", "1"]),  # the caller compiles again
    ("rtctl/sub/other.py", "2.0 * x", "3.0 * x", ["20.0", "3.0", "1", "0"]),  # the caller is reused
])
def test_a_closure_mutant_reuses_the_kernels_of_the_files_it_cannot_reach(tmp_path, mutated, old, new, expected):
    """What mutant_tests.py links for a mutant inside the kernel closure: the unmutated run's
    kernel files, by their owners, less those of the mutated file's dependents."""
    write(tmp_path, CALLS)
    warm, cache = tmp_path / "warm", tmp_path / "cache"

    def run(cache_dir: Path) -> list[str]:
        out = subprocess.run([sys.executable, "-c", RUN_CALLS], cwd=tmp_path, check=True, capture_output=True,
                             text=True, env={**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(cache_dir)})
        return out.stdout.split()

    assert run(warm) == ["20.0", "2.0", "0", "0"]  # (then: value, value, cache hits of each)
    owners = cache_owners(warm, tmp_path)
    assert sorted(set(owners.values())) == sorted(CALLS[f] and f for f in CALLS if CALLS[f].startswith("from numba"))
    assert len(owners) == sum(1 for p in warm.rglob("*") if p.is_file())  # every file has its owner
    (tmp_path / mutated).write_text((tmp_path / mutated).read_text().replace(old, new))
    dependents = kernel_dependents(tmp_path)
    state = {"warm": warm.name, "closure": sorted(dependents), "dependents": dependents, "owners": owners}
    linked = link_warm(warm, cache, reusable(state, mutated))
    assert linked == sum(1 for source in owners.values() if source not in dependents[mutated])
    assert run(cache) == expected


def test_a_line_in_a_function_maps_to_its_statement_and_kernels_are_marked():
    in_body, compiled = line_kinds(SOURCE)
    assert compiled == {4, 5, 6}  # decorator to end
    assert in_body[12] == 11 and in_body[11] == 11  # `x)` continues the statement coverage records at 11
    assert in_body[14] == 14 and in_body[13] == 13
    assert 9 not in in_body and 10 not in in_body  # the signature and its default run at import
    assert 1 not in in_body and 19 not in in_body  # module and class level
    assert in_body[22] == 22


def mutate(line: int, old: str, new: str) -> str:
    lines = SOURCE.splitlines(keepends=True)
    assert old in lines[line - 1]
    lines[line - 1] = lines[line - 1].replace(old, new, 1)
    return "".join(lines)


def test_the_mutated_lines_select_the_tests_that_ran_them_and_otherwise_all():
    covered = {11: ["t_clamp", "t_both"], 13: ["t_clamp"], 14: ["t_limit"], 22: ["t_area"], 1: ["t_import"],
               6: ["t_leaf_from_python"]}  # (a @leaf also runs as Python, and is then seen)
    assert changed_lines(SOURCE, mutate(13, ">", ">=")) == {13}
    assert select_tests(SOURCE, mutate(13, ">", ">="), covered) == {"t_clamp"}
    assert select_tests(SOURCE, mutate(12, "x)", "-x)"), covered) == {"t_clamp", "t_both"}  # (the statement's)
    assert select_tests(SOURCE, mutate(22, "*", "/"), covered) == {"t_area"}
    assert select_tests(SOURCE, mutate(6, ">", ">="), covered) is None  # inside a kernel: coverage is blind
    assert select_tests(SOURCE, mutate(1, "3", "4"), covered) is None  # module level
    assert select_tests(SOURCE, mutate(10, "-1", "-2"), covered) is None  # a default, evaluated at import
    assert select_tests(SOURCE, mutate(15, "y", "-y"), covered) is None  # no test ran it
    assert select_tests(SOURCE, mutate(19, "2", "3"), covered) is None  # class level


def test_coverage_contexts_name_the_tests_that_ran_each_line(tmp_path):
    pytest.importorskip("pytest_cov", reason="the mutation extra (pip install -e '.[mutation]') is not installed")
    write(tmp_path, {
        "pkg/__init__.py": "",
        "pkg/m.py": "def a(x):\n    return x + 1\n\n\ndef b(x):\n    return x - 1\n",
        "tests/test_m.py": """\
            import pytest
            from pkg.m import a, b
            def test_a():
                assert a(1) == 2
            @pytest.mark.parametrize("x", [1, 2])
            def test_b(x):
                assert b(x) == x - 1
            """,
    })
    (tmp_path / "rc").write_text(f"[run]\ninclude = {tmp_path}/pkg/m.py\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "COVERAGE_FILE": str(tmp_path / "cov")}
    base = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-o", "addopts="]
    order = [line for line in subprocess.run(base + ["--collect-only", "tests"], cwd=tmp_path, env=env,
                                             capture_output=True, text=True).stdout.splitlines() if "::" in line]
    assert order == ["tests/test_m.py::test_a", "tests/test_m.py::test_b[1]", "tests/test_m.py::test_b[2]"]
    run = subprocess.run(base + ["--cov", f"--cov-config={tmp_path / 'rc'}", "--cov-context=test", "--cov-report=",
                                 "tests"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout
    covered = lines_to_tests(tmp_path / "cov", tmp_path, ["pkg/m.py"], order)["pkg/m.py"]
    assert covered[2] == [0] and covered[6] == [1, 2]
    assert covered[1] == [] and covered[5] == []  # the def lines: at import only


def test_warm_kernels_are_linked_and_numba_never_writes_through_a_link(tmp_path):
    """A mutant's run that compiles a new signature rewrites the index: the unmutated run's copy stays."""
    write(tmp_path, {"k.py": "from numba import njit\n@njit(cache=True)\ndef f(x):\n    return x + 1\n"})
    warm, linked = tmp_path / "warm", tmp_path / "linked"

    def call(cache: Path, arg: str) -> None:
        subprocess.run([sys.executable, "-c", f"import k; k.f({arg})"], cwd=tmp_path, check=True,
                       env={**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(cache)})

    call(warm, "1")
    (warm / ".lock").write_text("")
    before = {p.relative_to(warm): p.read_bytes() for p in warm.rglob("*") if p.is_file()}
    link_warm(warm, linked)
    assert not (linked / ".lock").exists()
    assert all(os.path.samefile(warm / rel, linked / rel) for rel in before if rel.name != ".lock")
    call(linked, "1.5")  # a float: a second overload, a new index
    assert {p.relative_to(warm): p.read_bytes() for p in warm.rglob("*") if p.is_file()} == before
    index = next(p for p in linked.rglob("*.nbi"))
    assert not os.path.samefile(index, warm / index.relative_to(linked))


def test_tests_past_their_time_limit_are_a_time_out_and_leave_no_process_behind(tmp_path, capfd):
    """A "test run" that starts a child of its own and then hangs: at the limit both are killed
    (the whole process group) and the run is a time-out, rc 1; one within it keeps its status."""
    pid_file = tmp_path / "child.pid"
    hang = ("import subprocess, sys, time; p = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)']); "
            f"open({str(pid_file)!r}, 'w').write(str(p.pid)); time.sleep(60)")
    assert run_tests([sys.executable, "-c", hang], limit_s=2.0) == 1
    assert TIMED_OUT in capfd.readouterr().out
    child = int(pid_file.read_text())
    with pytest.raises(ProcessLookupError):  # (killed with the group; the parent reaped it or init did)
        for _ in range(100):
            os.kill(child, 0)
            time.sleep(0.05)
    assert run_tests([sys.executable, "-c", "import sys; sys.exit(3)"], limit_s=30.0) == 3


def test_a_stop_signal_kills_the_tests_process_group_and_is_no_verdict(tmp_path):
    """Stopping a run (SIGTERM to the test command) kills the tests' own session — a daemon the
    tests started goes too — and raises Stopped, which the command reports as a tool error (not
    a kill): the mutant runs again on --resume."""
    pid_file = tmp_path / "child.pid"
    hang = ("import subprocess, sys, time; p = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)']); "
            f"open({str(pid_file)!r}, 'w').write(str(p.pid)); time.sleep(60)")
    timer = threading.Timer(1.0, lambda: (pid_file.exists() or time.sleep(2), os.kill(os.getpid(), signal.SIGTERM)))
    before = signal.getsignal(signal.SIGTERM)
    timer.start()
    with pytest.raises(Stopped, match="SIGTERM"):
        run_tests([sys.executable, "-c", hang], limit_s=60.0)
    timer.join()
    assert signal.getsignal(signal.SIGTERM) is before  # (restored)
    child = int(pid_file.read_text())
    with pytest.raises(ProcessLookupError):
        for _ in range(100):
            os.kill(child, 0)
            time.sleep(0.05)


def test_a_targets_test_arguments_keep_their_options_and_lose_only_missing_files(tmp_path):
    """A run resumed after a test file moved drops that file, and nothing else: an option such
    as ``--deselect FILE`` keeps its value (dropping ``--deselect`` alone would turn the file it
    names into one more test to run)."""
    from run import existing_tests

    write(tmp_path, {"tests/a/test_x.py": "", "tests/a/test_slow.py": ""})
    words = ["tests/a", "--deselect", "tests/a/test_slow.py", "tests/gone.py", "tests/a/test_x.py::test_one"]
    assert existing_tests(words, tmp_path) == ["tests/a", "--deselect", "tests/a/test_slow.py",
                                               "tests/a/test_x.py::test_one"]


def test_a_resumed_run_makes_the_mutants_of_a_module_whose_sites_moved_again(tmp_path):
    """cosmic-ray applies "occurrence k of operator X": after an edit that moves a module's
    mutation sites, its recorded mutants name other sites. ``renew_moved_mutants`` makes that
    module's mutants again, as never run, and keeps the results of a module whose sites stayed
    (here one whose edit is inside a string) or moved with its docstring alone (its sites then
    recorded where they are now)."""
    pytest.importorskip("cosmic_ray", reason="the mutation extra (pip install -e '.[mutation]') is not installed")
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome, WorkResult
    from renewal import CR, record_code, renew_moved_mutants
    from run import plausible

    sources = {"a.py": "def f(x, y):\n    return x + y\n",
               "b.py": "def g(x):\n    return 'one' if x > 1 else 'two'\n",
               "c.py": 'def h(x):\n    """Twice x."""\n    return 2 * x\n'}
    for name, text in sources.items():
        (tmp_path / name).write_text(text)
    config, db = tmp_path / "cr.toml", tmp_path / "session.sqlite"
    modules = ", ".join(f'"{tmp_path / name}"' for name in sources)
    config.write_text(f'[cosmic-ray]\nmodule-path = [{modules}]\ntimeout = 10.0\n'
                      'excluded-modules = []\ntest-command = "true"\n\n[cosmic-ray.distributor]\nname = "local"\n')
    subprocess.run([*CR, "init", config, db], cwd=tmp_path, check=True, capture_output=True)
    record_code(db)  # (as run.py does after its init)
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        items = list(work_db.work_items)
        work_db.set_multiple_results([i.job_id for i in items], WorkResult(
            output="", test_outcome=TestOutcome.KILLED, worker_outcome=WorkerOutcome.NORMAL))

    def renew():
        return renew_moved_mutants(config, db, tmp_path, dict(os.environ), plausible)

    assert renew() == {}  # nothing moved: every result kept

    (tmp_path / "a.py").write_text("def f(x, y):\n    z = x - y\n    return x + y + z\n")
    (tmp_path / "b.py").write_text("def g(x):\n    return 'ONE' if x > 1 else 'TWO'\n")
    (tmp_path / "c.py").write_text('def h(x):\n    """Twice x:\n\n    two times x."""\n    return 2 * x\n')
    renewed = renew()
    assert list(renewed) == ["a.py"] and renewed["a.py"] > 0
    with use_db(str(db), WorkDB.Mode.open) as work_db:
        done = {str(i.mutations[0].module_path).rsplit("/", 1)[-1] for i, r in work_db.completed_work_items
                if r.worker_outcome != WorkerOutcome.SKIPPED}  # (a renewed module's implausible mutants: skipped)
        pending = list(work_db.pending_work_items)
    assert done == {"b.py", "c.py"} and {str(i.mutations[0].module_path).rsplit("/", 1)[-1] for i in pending} == {"a.py"}
    fresh = tmp_path / "check.sqlite"
    subprocess.run([*CR, "init", config, fresh], cwd=tmp_path, check=True, capture_output=True)
    sites = "SELECT module_path, operator_name, occurrence, start_pos_row, start_pos_col FROM mutation_specs ORDER BY 1, 2, 3"
    with sqlite3.connect(db) as con, sqlite3.connect(fresh) as ref:
        assert con.execute(sites).fetchall() == ref.execute(sites).fetchall()

    # a run from before the record (or one that lost it) cannot tell a docstring from code: made again
    db.with_name("mutants_made_from.json").unlink()
    (tmp_path / "c.py").write_text('def h(x):\n    """Twice x."""\n    return 2 * x\n')
    assert list(renew()) == ["c.py"]


def test_a_mutants_tests_run_quickest_first_keeping_each_files_tests_together():
    report = """
============================== slowest durations ===============================
3.10s call     tests/test_slow.py::test_long
0.40s setup    tests/test_slow.py::test_long
0.20s call     tests/test_fast.py::test_b[1-2]
0.05s call     tests/test_slow.py::test_short
0.01s teardown tests/test_fast.py::test_b[1-2]
(2 durations < 0.005s hidden.  Use -vv to show these durations.)
"""
    order = ["tests/test_slow.py::test_long", "tests/test_slow.py::test_short", "tests/test_fast.py::test_a",
             "tests/test_fast.py::test_b[1-2]", "tests/test_fast.py::test_c"]
    assert fastest_first(order, report) == [  # test_fast.py: 0.21 s in all, test_slow.py: 3.55 s
        "tests/test_fast.py::test_a", "tests/test_fast.py::test_c", "tests/test_fast.py::test_b[1-2]",
        "tests/test_slow.py::test_short", "tests/test_slow.py::test_long"]
