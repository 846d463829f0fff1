"""What the fuzzers share: TOML documents as nested dicts, the path of every key and array
element in them, mutations of one of those, `rtctl` run in-process under a time limit."""
from __future__ import annotations

import contextlib
import copy
import io
import math
import os
import signal

from hypothesis import HealthCheck, settings

# bounded, so the suite stays fast (RTCTL_FUZZ_EXAMPLES=2000 for a deep run); no example
# database: each run explores afresh
EXAMPLES = int(os.environ.get("RTCTL_FUZZ_EXAMPLES", "15"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

MUTATIONS = ("nan", "inf", "-inf", "negative", "zero", "huge", "huge int", "string", "bool", "table",
             "longer", "shorter", "delete", "extra key")
NON_FINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}


def leaves(value, path=()):
    """Every key path and array element path of a parsed TOML document."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield path + (k,)
            yield from leaves(v, path + (k,))
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield path + (i,)
            yield from leaves(v, path + (i,))


def key_name(path) -> str:
    """The key path as rtctl's messages write it: ``devices[0].bus.port``, ``waypoints[1][2]``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


def acceptable_names(path) -> tuple[str, ...]:
    """How an error about the element at ``path`` may name it: the element, the array holding
    it, or — for an element of an array of arrays (a polygon's vertex) — the key of the array."""
    array = path
    while isinstance(array[-1], int):
        array = array[:-1]
    return key_name(path), key_name(path[:-1]), key_name(array)


def get(doc, path):
    for p in path:
        doc = doc[p]
    return doc


def is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def mutate(doc, path, how: str):
    """A deep copy of ``doc`` with the value at ``path`` changed as ``how`` says."""
    doc = copy.deepcopy(doc)
    parent, last = get(doc, path[:-1]), path[-1]
    old = parent[last]
    if how == "delete":
        del parent[last]
    elif how == "extra key":
        target = old if isinstance(old, dict) else parent
        if isinstance(target, dict):
            target["fuzz_extra_key"] = 1
    elif how in ("longer", "shorter"):
        if isinstance(old, list):
            parent[last] = old + old[-1:] if how == "longer" else old[:-1]
        else:
            parent[last] = [old, old] if how == "longer" else []
    else:
        parent[last] = {
            "negative": -old if is_number(old) and old else -1, "zero": 0, "huge": 1e300, "huge int": 2**63 - 1,
            "string": "fuzz", "bool": True, "table": {"fuzz": 1},
        }.get(how, NON_FINITE.get(how))
    return doc


class Hang(Exception):
    pass


@contextlib.contextmanager
def time_limit(seconds: float):
    """Raise Hang if the block runs longer than ``seconds`` (SIGALRM: main thread only)."""
    def on_alarm(signum, frame):
        raise Hang(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def rtctl_in_process(*argv, timeout: float = 30.0) -> tuple[int, str, str]:
    """``rtctl ARGV`` in this process: (exit code, stdout, stderr). Any exception but
    SystemExit escapes: for rtctl that is a traceback, i.e. a bug."""
    from rtctl.cli import main

    out, err = io.StringIO(), io.StringIO()
    with time_limit(timeout), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as e:  # argparse
            code = e.code
    return code, out.getvalue(), err.getvalue()
