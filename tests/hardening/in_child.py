"""Run a function in a child Python process, so that a signal death (a segfault in a compiled
kernel reading a wild index) fails the test that asked instead of killing pytest.

``run("module:function", arg, …)`` imports ``module`` (from tests/hardening) in a fresh
interpreter with the fault handler on, calls ``function(*args)`` and returns what it returned
(JSON). A child that dies, raises or hangs is an AssertionError carrying its last output: the
fault handler's traceback names the line that crashed, hypothesis's report the input."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
MARK = "CHILD-RESULT "

_MAIN = """
import importlib, json, sys
sys.path.insert(0, {here!r})
module, function = {target!r}.split(":")
result = getattr(importlib.import_module(module), function)(*{args!r})
print({mark!r} + json.dumps(result), flush=True)
"""


def run(target: str, *args, timeout: float = 120.0):
    code = _MAIN.format(here=str(HERE), target=target, args=args, mark=MARK)
    try:
        proc = subprocess.run([sys.executable, "-X", "faulthandler", "-c", code], capture_output=True, text=True,
                              timeout=timeout, cwd=ROOT)
    except subprocess.TimeoutExpired as e:
        raise AssertionError(f"{target}{args} still running after {timeout} s: {(e.stderr or b'')[-3000:]!r}") from None
    if proc.returncode < 0:
        raise AssertionError(f"{target}{args}: the child died of {signal.Signals(-proc.returncode).name}:\n"
                             f"{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}")
    lines = [line for line in proc.stdout.splitlines() if line.startswith(MARK)]
    if proc.returncode or not lines:
        raise AssertionError(f"{target}{args}: the child exited {proc.returncode}:\n{proc.stdout[-2000:]}\n"
                             f"{proc.stderr[-6000:]}")
    return json.loads(lines[-1][len(MARK):])
