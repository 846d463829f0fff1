"""Issue 25 defect 6: the operator's commands import only what they need — an `estop` that
imported numba (through rtctl.logic) took 1.3–2.5 s before it reached the daemon. The time is
measured by `rtctl bench control-socket`; this checks the structure that keeps it short."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numpy", "numba", "scipy", "structlog", "rtctl.logic", "rtctl.config", "rtctl.model", "rtctl.daemon")
CHILD = """
import json, sys
from rtctl.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


@pytest.mark.parametrize("argv", [["estop"], ["stop"], ["status"], ["reset"], ["move", "0", "0", "0", "0", "0", "0"]])
def test_a_control_command_imports_nothing_heavy(argv, tmp_path):
    r = subprocess.run([sys.executable, "-c", CHILD, *argv, "--socket", str(tmp_path / "none.sock")],
                       capture_output=True, text=True, timeout=60)
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["code"] == 6  # no daemon there: exit 6, said on stderr
    heavy = [m for m in out["modules"] if m.split(".")[0] in HEAVY or any(m.startswith(h) for h in HEAVY if "." in h)]
    assert not heavy, heavy
