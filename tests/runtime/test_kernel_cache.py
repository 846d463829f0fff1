"""rtctl.kernel_cache: a compiled kernel never outlives the sources it was compiled from.

numba checks a cached kernel against its own file only; these tests edit a *callee* in another
file of a scratch copy of the packages and run the caller again in a new process, as a user
does after an update. Each run is a fresh interpreter on the copy (``PYTHONPATH``), with the
cache where rtctl puts it by default (the copy's ``rtctl/__pycache__``) unless said otherwise.
"""
from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("rtctl", "drivers", "hil_sim")

CALLEE = textwrap.dedent("""
    from rtctl.compiled import kernel

    OFFSET = 1.0

    @kernel
    def shifted(x):
        return x + OFFSET
""")

CALLER = textwrap.dedent("""
    from rtctl.compiled import kernel
    from {package}.probe_callee import shifted

    @kernel
    def scaled(x):
        return 10.0 * shifted(x)
""")

RUN = textwrap.dedent("""
    import os, sys
    import rtctl
    from rtctl.probe_caller import scaled
    from rtctl.warmup import count_compilations
    assert rtctl.__file__.startswith(sys.argv[1]), rtctl.__file__
    out = []
    compiled = count_compilations(lambda: out.append(scaled(1.0)))
    print(out[0], compiled, os.environ.get("NUMBA_CACHE_DIR", "-"))
""")


def _copy(tmp_path: Path) -> Path:
    tree = tmp_path / "tree"
    for name in PACKAGES:
        shutil.copytree(ROOT / name, tree / name, ignore=shutil.ignore_patterns("__pycache__"))
    return tree


def _run(tree: Path, env: dict | None = None, code: str = RUN) -> tuple[float, int, Path]:
    """(scaled(1.0), how many functions it compiled, the kernel directory) in a new process."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"} | {"PYTHONPATH": str(tree)} | (env or {})
    result = subprocess.run([sys.executable, "-c", code, str(tree)], cwd=tree, env=env, capture_output=True,
                            text=True, timeout=240)
    assert result.returncode == 0, result.stderr[-3000:]
    value, compiled, cache = result.stdout.split()
    return float(value), int(compiled), Path(cache)


@pytest.mark.parametrize("package", PACKAGES)
def test_a_caller_recompiles_when_only_its_callee_in_another_file_changes(tmp_path, package):
    tree = _copy(tmp_path)
    (tree / package / "probe_callee.py").write_text(CALLEE)
    (tree / "rtctl" / "probe_caller.py").write_text(CALLER.format(package=package))

    assert _run(tree)[:2] == (20.0, 2)  # 10 · (1 + 1); both compiled
    assert _run(tree)[:2] == (20.0, 0)  # loaded from the cache: it is used
    callee = tree / package / "probe_callee.py"
    callee.write_text(callee.read_text().replace("OFFSET = 1.0", "OFFSET = 2.0"))
    value, compiled, _ = _run(tree)
    assert value == 30.0  # 10 · (1 + 2): numba alone answers 20.0, its cache of the caller is stale
    assert compiled == 2


def test_the_cache_follows_the_sources_and_the_stale_one_is_removed(tmp_path):
    tree = _copy(tmp_path)
    (tree / "rtctl" / "probe_callee.py").write_text(CALLEE)
    (tree / "rtctl" / "probe_caller.py").write_text(CALLER.format(package="rtctl"))
    pycache = tree / "rtctl" / "__pycache__"
    legacy = tree / "rtctl" / "control" / "__pycache__" / "gmv.gmv_law-51.py311.nbi"  # numba's old in-tree cache
    legacy.parent.mkdir(parents=True)
    legacy.write_bytes(b"stale")
    foreign = pycache / "rtctl-kernels-nothex"  # not a name rtctl gives: left alone
    foreign.mkdir(parents=True)

    _, _, first = _run(tree)
    assert first.parent == pycache and first.is_dir()
    assert not legacy.exists() and foreign.is_dir()

    (tree / "rtctl" / "errors.py").write_text((tree / "rtctl" / "errors.py").read_text() + "\n# an update\n")
    _, compiled, second = _run(tree)
    assert second.parent == pycache and second != first
    assert compiled == 2
    assert not first.exists()  # the old sources' kernels are gone
    assert sorted(p.name for p in pycache.iterdir() if p.is_dir()) == sorted([second.name, foreign.name])


def test_a_cache_in_use_is_kept_and_a_child_process_finds_the_same_one(tmp_path):
    """A directory locked by a running process (here: this test) survives another version's
    start; a child inheriting ``NUMBA_CACHE_DIR`` from rtctl uses that same directory."""
    tree = _copy(tmp_path)
    (tree / "rtctl" / "probe_callee.py").write_text(CALLEE)
    (tree / "rtctl" / "probe_caller.py").write_text(CALLER.format(package="rtctl"))
    base = tmp_path / "numba-cache"
    busy = base / "rtctl-kernels-0123456789abcdef"
    busy.mkdir(parents=True)
    with open(busy / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_SH)
        _, _, used = _run(tree, {"NUMBA_CACHE_DIR": str(base)})
        assert busy.is_dir()
    assert used.parent == base
    _, compiled, again = _run(tree, {"NUMBA_CACHE_DIR": str(used)})  # what a child of that run sees
    assert again == used and compiled == 0
    _run(tree, {"NUMBA_CACHE_DIR": str(base)})
    assert not busy.exists()  # unlocked now: removed at the next start


PAST_THE_END = textwrap.dedent("""
    import numpy as np
    import rtctl  # (before numba: rtctl chooses the kernel directory)
    from rtctl.probe_past import past
    try:
        past(np.zeros(3))
        print("read")
    except IndexError:
        print("IndexError")
""")


def test_a_kernel_cached_without_bounds_checks_is_not_reused_with_them(tmp_path):
    """numba's cache index holds no compile settings: after a run without ``NUMBA_BOUNDSCHECK``,
    a run with it would load the unchecked kernel and read past the array. rtctl keys its
    directory on the settings that change the machine code, so the second run compiles."""
    tree = _copy(tmp_path)
    (tree / "rtctl" / "probe_past.py").write_text(textwrap.dedent("""
        from rtctl.compiled import kernel

        @kernel
        def past(a):
            return a[a.shape[0] + 2]
    """))

    def outcome(env=None):
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "NUMBA_BOUNDSCHECK")} \
            | {"PYTHONPATH": str(tree)} | (env or {})
        result = subprocess.run([sys.executable, "-c", PAST_THE_END], cwd=tree, env=env, capture_output=True,
                                text=True, timeout=240)
        assert result.returncode == 0, result.stderr[-3000:]
        return result.stdout.strip()

    assert outcome() == "read"  # compiled without the check, and cached
    assert outcome({"NUMBA_BOUNDSCHECK": "1"}) == "IndexError"
    assert outcome() == "read"
