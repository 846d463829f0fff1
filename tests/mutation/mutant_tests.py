"""cosmic-ray's test command for one planted mutant (written for tests/mutation/run.py, which
copies this file and selection.py into ``<tree>/.mutation/`` with what the unmutated run
recorded there in ``baseline.json``). Run in the copy's root; exits with pytest's status.

``MUTATION_MODE=fast`` (the first pass): the mutant's file is found by its changed hash and
its lines by a diff with the pristine copy. A file outside the kernel closure gets the
unmutated run's compiled kernels, hard-linked under the name of the mutated tree's source hash
(numba writes its index and data files to a temporary name and renames them, so a link is
never written through); a file inside it starts from an empty cache. Only the tests that
executed the mutated lines run; where coverage cannot tell, all of them; either way the quickest
first (:func:`selection.fastest_first`), as the first failure ends the run.

``MUTATION_MODE=full`` (the second pass, for every survivor of the first): the target's full
tests from an empty cache, as a run without this tool would do. A survivor counts only here.

A failure counts as a kill only when it reproduces (:func:`confirmed_status`): the first failed
test alone again, and if it passes, all the tests once more. A test that a loaded machine can fail
(a real-time bound, a frame count) would otherwise kill an equivalent mutant now and then — the
second pass runs the HIL tests while another shard loads the other core — and the kill rate
would read better than the tests are.

A mutant's tests get :func:`time_limit` of the unmutated run's time (which ran them all, from
an empty cache, under coverage): a mutant that loops forever is a time-out after about two
minutes instead of cosmic-ray's per-target limit of four to ten. The whole process group is
killed (tests start daemons) and the run counts as a time-out, as cosmic-ray's own would.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from selection import select_tests, tree_cache_key  # noqa: E402  (this file's directory, after the path)

PYTEST = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-p", "no:randomly", "-o", "addopts="]
PREFIX = "rtctl-kernels-"


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


TOOL_ERROR = "MUTATION-TOOL-ERROR"  # (run.py stops on it: a crash of this tool must not count as a kill)
TIMED_OUT = "MUTATION-TIMED-OUT"  # (run.py counts it as a time-out, not as a kill by a test)
NOT_REPRODUCED = "MUTATION-NOT-REPRODUCED"  # (a failure that did not happen again: not a kill by itself)


def time_limit(baseline_s: float) -> float:
    """How long a mutant's tests may take: three times the unmutated run, and a minute more for a
    machine busier than it was then."""
    return 3.0 * baseline_s + 60.0


class Stopped(Exception):
    """The run is being stopped (SIGTERM, SIGHUP or SIGINT to this process)."""


def _stop(signum, frame):
    raise Stopped(signal.Signals(signum).name)


def run_tests(argv: list[str], limit_s: float, output: list[str] | None = None) -> int:
    """pytest's exit status; at ``limit_s`` its process group is killed and it is a time-out (1).
    A stop signal kills the group too and raises :class:`Stopped`: pytest runs in a session of
    its own (its daemons with it), which a signal to the run's process group does not reach.
    Its output goes to this process's (cosmic-ray keeps it), and its lines to ``output`` if given."""
    proc = subprocess.Popen(argv, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    echo = threading.Thread(target=_echo, args=(proc.stdout, output if output is not None else []), daemon=True)
    echo.start()
    previous = {s: signal.signal(s, _stop) for s in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)}
    try:
        rc = proc.wait(timeout=limit_s)
        echo.join(timeout=10.0)  # (a daemon that left pytest's session may hold the pipe open)
        return rc
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        print(f"{TIMED_OUT}: the tests ran past {limit_s:.0f} s", flush=True)
        return 1
    except Stopped:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        raise
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _echo(stream, lines: list[str]) -> None:
    for line in stream:
        sys.stdout.write(line)
        lines.append(line.rstrip("\n"))
    sys.stdout.flush()


_FAILURE = re.compile(r"(?:FAILED|ERROR) (\S+?)(?: - .*)?$")  # pytest's short summary: "FAILED tests/a.py::t[x] - msg"


def first_failure(lines: list[str]) -> str | None:
    """The node id of the first failed test in pytest's short summary (``-r fE``, its default)."""
    for line in lines:
        if (found := _FAILURE.match(line)) is not None and "::" in found.group(1):
            return found.group(1)
    return None


def confirmed_status(argv: list[str], limit_s: float, run=run_tests) -> tuple[int, str | None]:
    """pytest's exit status for ``argv``, a failure of a test confirmed: that test fails again
    alone (1, "reproduced"), or else all of ``argv`` run once more decide ("not reproduced").
    → (status, None) for a pass, a time-out, or a failure that names no test (a collection error)."""
    output: list[str] = []
    rc = run(argv, limit_s, output)
    failing = first_failure(output) if rc == 1 else None
    if failing is None:
        return rc, None
    if run(PYTEST + [failing], limit_s) == 1:
        return 1, "reproduced"
    print(f"{NOT_REPRODUCED}: {failing} passed when run again alone; all the tests once more", flush=True)
    return run(argv, limit_s), "not reproduced"


def link_warm(warm: Path, dest: Path, reuse=None) -> int:
    """Hard-link the kernel files under ``warm`` into ``dest`` (not the lock: each directory has
    its own): every one, or those whose path relative to ``warm`` ``reuse`` accepts. → how many."""
    linked = 0

    def skip(folder: str, names: list[str]) -> list[str]:
        nonlocal linked
        rel = Path(folder).relative_to(warm)
        dropped = [n for n in names if n == ".lock" or (reuse is not None and (Path(folder) / n).is_file()
                                                        and not reuse(str(rel / n)))]
        linked += sum(1 for n in names if n not in dropped and (Path(folder) / n).is_file())
        return dropped

    shutil.copytree(warm, dest, copy_function=os.link, ignore=skip)
    return linked


def reusable(state: dict, rel: str):
    """Which of the unmutated run's kernel files a mutant in ``rel`` may reuse: every one
    (``True``: outside the kernel closure), those of the files it cannot reach (a predicate on
    a file's path under the warm directory; a file of no known source is never reused), or none
    (``False``: no warm kernels, or a file that rebinds other modules' globals reaches ``rel``)."""
    if not state["warm"]:
        return False
    if rel not in state["closure"]:
        return True
    stale = state["dependents"].get(rel)
    if stale is None:
        return False
    stale = {*stale, rel}
    return lambda entry: state["owners"].get(entry, rel) not in stale


def main() -> int:
    try:
        return run()
    except Stopped as stop:  # (not a verdict: run.py drops it, and --resume runs the mutant again)
        print(TOOL_ERROR, f"stopped by {stop}", flush=True)
        return 99
    except Exception:  # (only the tool's own failures: pytest runs in a subprocess)
        print(TOOL_ERROR, traceback.format_exc(), flush=True)
        return 99


def run() -> int:
    started = time.monotonic()
    tree = Path.cwd()
    state = json.loads((HERE / "baseline.json").read_text())
    full = os.environ.get("MUTATION_MODE", "fast") == "full"
    mutated = [rel for rel, sha in state["files"].items() if digest(tree / rel) != sha]
    cache = tree / ".numba"
    shutil.rmtree(cache, ignore_errors=True)  # (the previous mutant's kernels, or a stopped run's)
    cache.mkdir()
    rel = mutated[0] if len(mutated) == 1 else None
    selected, warm = None, "empty"
    if not full and rel is not None:
        reuse = reusable(state, rel)
        if reuse is not False:
            n = link_warm(HERE / "warm" / state["warm"], cache / (PREFIX + tree_cache_key(tree, os.environ)),
                          None if reuse is True else reuse)
            warm = "warm" if reuse is True else f"partly warm ({n} of {len(state['owners'])} kernel files)"
        covered = {int(line): [state["order"][i] for i in ids]
                   for line, ids in state["covered"].get(rel, {}).items()}
        chosen = select_tests((HERE / "pristine" / rel).read_text(), (tree / rel).read_text(), covered)
        if chosen is not None:
            selected = [t for t in state["order"] if t in chosen]
    everything = state["tests"].split() if full else state["order"]  # (the fast pass: quickest first)
    argv = PYTEST + (selected if selected is not None else everything)
    print(f"mutant in {rel}: {'all' if selected is None else len(selected)} tests, "
          f"{warm} kernel cache ({'full' if full else 'fast'} pass)", flush=True)
    limit = time_limit(state["seconds"])
    rc, failure = confirmed_status(argv, limit)
    if selected is not None and rc in (4, 5):  # (a test id pytest could not find again: all of them)
        selected = None
        rc, failure = confirmed_status(PYTEST + state["tests"].split(), limit)
    with open(HERE / "log.jsonl", "a") as log:
        log.write(json.dumps({"file": rel, "pass": "full" if full else "fast", "warm": warm,
                              "tests": None if selected is None else len(selected), "rc": rc, "failure": failure,
                              "seconds": round(time.monotonic() - started, 2)}) + "\n")
    return rc


if __name__ == "__main__":
    sys.exit(main())
