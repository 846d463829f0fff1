"""Run model-API calls in a child process, so a segfault fails a test instead of killing pytest.

``run_child(source)`` executes ``source`` (Python) with ``python -X faulthandler`` and returns
the CompletedProcess; the child prints one JSON line per finished call (see ``PRELUDE``), and
the name of each call before it is made, so the call that crashed is the last one named."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PRELUDE = '''
import json, sys
import numpy as np
from rtctl.errors import RtctlError

def outcome(name, call):
    print(json.dumps({"calling": name}), flush=True)
    try:
        result = call()
    except (ValueError, TypeError, RtctlError) as e:
        print(json.dumps({"case": name, "raised": type(e).__name__, "message": str(e)}), flush=True)
        return
    values = [np.asarray(r, dtype=float) for r in (result if isinstance(result, tuple) else (result,))
              if not hasattr(r, "sigma_min")]
    finite = all(np.all(np.isfinite(v)) for v in values)
    print(json.dumps({"case": name, "returned": True, "finite": bool(finite)}), flush=True)
'''


def run_child(source: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-X", "faulthandler", "-c", PRELUDE + textwrap.dedent(source)],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)


def outcomes(result) -> dict:
    import json

    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    crashed = [x["calling"] for x in lines if "calling" in x]
    assert result.returncode == 0, (f"the child died ({result.returncode}) in {crashed[-1:]}: "
                                    f"{result.stderr[-2000:]}")
    return {x["case"]: x for x in lines if "case" in x}
