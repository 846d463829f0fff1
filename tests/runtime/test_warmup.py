"""rtctl.warmup.Precompile: cached kernels load in the daemon's process; missing ones compile in
forked workers while it logs what happens; a failed worker costs time, not the run.

Each scenario runs in a fresh interpreter (forks from a threaded pytest process would be
refused, and numba's cache must start cold) with its own NUMBA_CACHE_DIR, and reads back the
JSON log lines it wrote.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.realtime  # (tests/conftest.py)

SCENARIO = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, {module_dir!r})
    from rtctl import logs
    logs.configure("json")
    import kernels_under_test as k
    from rtctl.warmup import Precompile

    def slow():  # a compilation that takes longer than the heartbeat (in a worker)
        k.add(1.0, 2.0)
        time.sleep(2.6)

    def fails():
        raise RuntimeError("broken group")

    class Loading:  # a thread while the cached kernels load, as the daemon's socket server
        def __enter__(self):
            import threading
            self.done = threading.Event()
            self.thread = threading.Thread(target=self.done.wait)
            self.thread.start()
        def __exit__(self, *exc):
            self.done.set()
            self.thread.join()
            print("LOADING LEFT", flush=True)

    stopped = []

    def stop_now():  # a stop that comes while the first group loads
        stopped.append(True)
        k.add_once()

    def asked():
        print("STOP ASKED", flush=True)
        return bool(stopped)

    groups = {{"ok": [("add", k.add_once), ("mul", k.mul_once)],
               "served": [("add", k.add_once), ("mul", k.mul_once)],
               "stopped": [("stop", stop_now), ("mul", k.mul_once)],
               "slow": [("slow", slow)],
               "fails": [("add", k.add_once), ("broken", fails)]}}[sys.argv[1]]
    p = Precompile(groups).start(loading=Loading() if sys.argv[1] == "served" else None, stop=asked)
    print("WORKERS", len(p.workers), flush=True)
    if sys.argv[1] == "stopped":
        print("LOADED", p.loaded, flush=True)
        sys.exit(0)
    assert p.wait()
    try:
        p.finish()
    except RuntimeError as e:
        print("RAISED", e, flush=True)
""")

KERNELS = textwrap.dedent("""
    from numba import njit

    @njit(cache=True)
    def add(a, b):
        return a + b

    @njit(cache=True)
    def mul(a, b):
        return a * b

    def add_once():
        return add(1.0, 2.0)

    def mul_once():
        return mul(1.0, 2.0)
""")


def _run(tmp_path, scenario: str):
    (tmp_path / "kernels_under_test.py").write_text(KERNELS)
    script = tmp_path / "scenario.py"
    script.write_text(SCENARIO.format(module_dir=str(tmp_path)))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    result = subprocess.run([sys.executable, str(script), scenario], capture_output=True, text=True, env=env,
                            timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.splitlines()
    events = [json.loads(line) for line in lines if line.startswith("{")]
    plain = [line for line in lines if not line.startswith("{")]
    return events, plain


def _named(events, name):
    return [e for e in events if e["event"] == name]


def test_a_cold_cache_compiles_in_workers_and_a_warm_one_loads_in_the_daemon(tmp_path):
    events, plain = _run(tmp_path, "ok")
    (preparing,) = _named(events, "preparing kernels")
    assert preparing["compile"] == ["add", "mul"] and preparing["workers"] >= 1
    assert sorted(e["group"] for e in _named(events, "kernels ready")) == ["add", "mul"]
    assert all(e["compiled"] == 1 for e in _named(events, "kernels ready"))  # each compiled its own kernel
    assert _named(events, "kernels loaded")[-1]["compiled"] == 0  # the daemon then only loads them

    events, plain = _run(tmp_path, "ok")  # the same cache: nothing to compile, no worker
    assert "WORKERS 0" in plain and not _named(events, "preparing kernels")
    (loaded,) = _named(events, "kernels loaded")
    assert loaded["compiled"] == 0


def test_a_long_compilation_is_never_silent_for_more_than_the_heartbeat(tmp_path):
    events, _ = _run(tmp_path, "slow")
    beats = _named(events, "compiling kernels")
    assert beats and all(b["waiting_for"] == ["slow"] for b in beats)  # it says what it waits for
    assert len(beats) >= 2  # 2.6 s of work, a line at least every second


def test_a_failed_group_is_reported_and_then_raised_by_the_daemon_itself(tmp_path):
    events, plain = _run(tmp_path, "fails")
    (failed,) = _named(events, "kernel group failed")
    assert failed["group"] == "broken" and "broken group" in failed["error"]
    assert "RAISED broken group" in plain  # finish() runs it here: the real error, not a lost one


def test_the_loading_context_is_left_before_the_workers_fork(tmp_path):
    """The daemon serves its socket from a thread while cached kernels load; a fork keeps only
    the forking thread (a lock held elsewhere stays held), so Precompile forks no worker while
    another thread runs: that thread must be gone first, or a cold start compiles serially."""
    events, plain = _run(tmp_path, "served")
    assert "LOADING LEFT" in plain
    (preparing,) = _named(events, "preparing kernels")
    assert preparing["workers"] >= 1, preparing  # the thread was joined before the fork


def test_a_stop_while_kernels_load_forks_no_worker_and_loads_nothing_more(tmp_path):
    """A stop that comes while a group loads (here: the group itself asks for it): the next
    group is neither loaded nor handed to a forked worker — the start is over anyway."""
    events, plain = _run(tmp_path, "stopped")
    assert "WORKERS 0" in plain and "LOADED 0" in plain, plain  # (its first group missed the cold cache)
    assert not _named(events, "preparing kernels")
    (left,) = _named(events, "kernels not prepared")
    assert left["left"] == ["stop", "mul"], left

    _run(tmp_path, "ok")  # a warm cache: the first group loads, and the stop ends the loading there
    events, plain = _run(tmp_path, "stopped")
    assert "WORKERS 0" in plain and "LOADED 1" in plain, plain
    (left,) = _named(events, "kernels not prepared")
    assert left["left"] == ["mul"], left
