"""Fuzzing the public model API in a child process (model_api_fuzz_child.py), so that a
segfault fails this test — naming the call — instead of killing pytest: random shapes, dtypes,
layouts and values into every kinematics and dynamics function, a clear exception or a finite
result. RTCTL_FUZZ_EXAMPLES sets the calls per function (15 here, 600 for a deep run)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

CHILD = Path(__file__).with_name("model_api_fuzz_child.py")


def test_fuzz_model_api_in_a_child_process():
    examples = os.environ.get("RTCTL_FUZZ_EXAMPLES", "15")
    result = subprocess.run([sys.executable, "-X", "faulthandler", str(CHILD), examples],
                            capture_output=True, text=True, timeout=600)
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    calls = [x["calling"] for x in lines if "calling" in x]
    assert result.returncode == 0, (f"the child failed ({result.returncode}) in {calls[-1:]}:\n"
                                    f"{result.stderr[-4000:]}")
    assert lines[-1] == {"done": True}
    assert len(set(calls)) >= 24  # every function was called
