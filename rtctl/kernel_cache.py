"""Where numba keeps rtctl's compiled kernels: a directory named after the sources they came from.

numba checks a cached kernel against its own source file only. A kernel that calls a kernel
(or reads a constant) from another file keeps its old machine code when only that other file
changes — after an update, a controller or the safety stage would run code that is no longer
in the sources. So every process that imports rtctl, and then numba, points ``NUMBA_CACHE_DIR`` at
``<base>/rtctl-kernels-<hash>``, the hash taken over the content of every ``.py`` file of the
packages that hold kernels (rtctl, drivers, hil_sim; about 180 files, 5–7 ms; no kernel reads
their other files) and over the numba settings that change the machine code without being in
numba's own cache key (:data:`CODEGEN_SETTINGS`). Any changed source, whatever the version
number says, or such a setting starts an empty cache; nothing else does.

``<base>`` is ``NUMBA_CACHE_DIR`` if the user set one; else the rtctl package's
``__pycache__`` (a source checkout or a writable site-packages); else a per-installation
directory in the user's cache (``~/.cache/rtctl/``). A child process (the warm-up's forked
workers, the spawned move planner, a HIL simulator) inherits ``NUMBA_CACHE_DIR`` and,
importing rtctl, finds the same directory — or a new one if the sources changed meanwhile.

Each process holds a shared lock on its directory while it lives. The directories of other
sources in the same base are removed once nobody holds them (the kernels of an earlier
version; between the runs of a mutation test, the previous mutant's), as are the in-tree
caches numba wrote before this scheme (``*.nbi``/``*.nbc`` in the packages' ``__pycache__``).
"""
from __future__ import annotations

import fcntl
import hashlib
import importlib.util
import os
import re
import sys
import warnings
from collections.abc import Mapping
from pathlib import Path

PACKAGES = ("rtctl", "drivers", "hil_sim")  # every package that defines or calls a kernel
PREFIX = "rtctl-kernels-"
_NAME = re.compile(re.escape(PREFIX) + r"[0-9a-f]{16}")
_LOCK = ".lock"
# numba settings that change the machine code it caches but not its cache index (which holds the
# signature, the CPU and the bytecode): a kernel compiled under another value would be reused as
# it was — with NUMBA_BOUNDSCHECK=1, set to find a bad index, a cached kernel would check nothing.
CODEGEN_SETTINGS = ("NUMBA_BOUNDSCHECK", "NUMBA_OPT", "NUMBA_LOOP_VECTORIZE", "NUMBA_SLP_VECTORIZE",
                    "NUMBA_ENABLE_AVX", "NUMBA_DEBUGINFO", "NUMBA_EXTEND_VARIABLE_LIFETIMES", "NUMBA_DEBUG_NRT")
_held: int | None = None  # this process's lock on its directory (kept open for its lifetime)


def source_dirs() -> list[Path]:
    """The packages' directories, as they would be imported (nothing is imported)."""
    dirs = []
    for name in PACKAGES:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.submodule_search_locations:
            dirs.extend(Path(d) for d in spec.submodule_search_locations)
    return dirs


def cache_key(dirs: list[Path], environ: Mapping[str, str]) -> str:
    """16 hex digits over the relative path and content of every ``.py`` file under ``dirs``
    and the :data:`CODEGEN_SETTINGS` that ``environ`` gives."""
    h = hashlib.blake2b(digest_size=8)
    h.update(repr([(k, environ[k]) for k in CODEGEN_SETTINGS if k in environ]).encode())
    for top in dirs:
        skip = len(str(top.parent)) + 1  # paths relative to the package's parent: same in every copy
        for root, subdirs, files in os.walk(top):
            subdirs[:] = sorted(d for d in subdirs if d != "__pycache__" and not d.startswith("."))
            for name in sorted(files):
                if name.endswith(".py"):
                    path = os.path.join(root, name)
                    with open(path, "rb") as f:
                        data = f.read()
                    rel = path[skip:].encode()
                    h.update(b"%d:%s:%d:" % (len(rel), rel, len(data)))
                    h.update(data)
    return h.hexdigest()


def _bases(package_dir: Path) -> list[Path]:
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:  # the user's choice — or, in a child process, the directory its parent chose
        path = Path(given)
        return [path.parent if _NAME.fullmatch(path.name) else path]
    bases = [package_dir / "__pycache__"]
    try:
        user = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    except RuntimeError:  # no home directory to be found
        return bases
    install = hashlib.blake2b(str(package_dir).encode(), digest_size=6).hexdigest()
    return [*bases, user / "rtctl" / install]


class SelectBeforeNumba:
    """An import hook (``sys.meta_path``) that finds nothing: :func:`select` runs when numba is
    first imported, before it reads its settings; the import then proceeds as usual. It stays
    in the list (removing itself while the import system walks the list would skip the next
    finder)."""

    selected = False

    @staticmethod
    def find_spec(name, path=None, target=None):
        if name == "numba" and not SelectBeforeNumba.selected:
            SelectBeforeNumba.selected = True
            select()
        return None


def select() -> Path | None:
    """Point numba at the kernel directory for the current sources (made and locked here) and
    remove the stale ones. Runs when numba is first imported in a process that imported rtctl
    (:class:`SelectBeforeNumba`), before any kernel is defined. Returns the directory (None:
    nowhere writable, numba keeps its own default)."""
    global _held
    dirs = source_dirs()
    name = PREFIX + cache_key(dirs, os.environ)
    bases = _bases(Path(__file__).resolve().parent)
    for base in bases:
        try:
            _held, fresh = _hold(base / name)
        except OSError:
            continue
        os.environ["NUMBA_CACHE_DIR"] = str(base / name)
        if "numba.core.config" in sys.modules:  # numba has read its settings already: again
            sys.modules["numba.core.config"].reload_config()
        _remove_stale(base, keep=name)
        if fresh:
            _remove_in_tree(dirs)
        return base / name
    warnings.warn("rtctl: compiled kernels are not cached, no directory is writable: "
                  + ", ".join(str(b / name) for b in bases), stacklevel=2)
    return None


def _hold(path: Path) -> tuple[int, bool]:
    """Make ``path`` and take a shared lock on it; (the lock's descriptor, whether it was new).
    If another process removed it between our mkdir and our lock, make it again."""
    while True:
        fresh = not path.is_dir()
        path.mkdir(parents=True, exist_ok=True)
        fd = os.open(path / _LOCK, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        fcntl.flock(fd, fcntl.LOCK_SH)
        try:
            if os.path.samestat(os.fstat(fd), os.stat(path / _LOCK)):
                return fd, fresh
        except FileNotFoundError:
            pass
        os.close(fd)


def _remove_stale(base: Path, keep: str) -> None:
    """Remove the other sources' kernel directories in ``base`` that no process holds."""
    import shutil  # here, not at the top: importing it costs 4 ms, at every start

    for entry in os.scandir(base):
        if entry.name == keep or not _NAME.fullmatch(entry.name) or not entry.is_dir(follow_symlinks=False):
            continue
        try:
            fd = os.open(os.path.join(entry.path, _LOCK), os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # fails while a process runs on it
            shutil.rmtree(entry.path, ignore_errors=True)
        except OSError:
            pass
        finally:
            os.close(fd)


def _remove_in_tree(dirs: list[Path]) -> None:
    """Remove what numba cached next to the sources before this scheme (``__pycache__/*.nbi``,
    ``*.nbc`` of our packages): never read again, and stale in the same way."""
    for top in dirs:
        for root, subdirs, files in os.walk(top):
            subdirs[:] = [d for d in subdirs if not _NAME.fullmatch(d)]
            if os.path.basename(root) == "__pycache__":
                for name in files:
                    if name.endswith((".nbi", ".nbc")):
                        Path(root, name).unlink(missing_ok=True)
