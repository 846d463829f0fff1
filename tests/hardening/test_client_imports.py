"""Issue 25 defect 6: the operator's commands import only what they need — an `estop` that
imported numba (through rtctl.logic) took 1.3–2.5 s before it reached the daemon. The time is
measured by `rtctl bench control-socket`; this checks the structure that keeps it short."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

HEAVY = ("numpy", "numba", "scipy", "structlog", "rtctl.logic", "rtctl.config", "rtctl.model", "rtctl.daemon")
CHILD = """
import json, sys
from rtctl.cli import main
code = main(sys.argv[1:])
import os
print(json.dumps({"code": code, "modules": sorted(sys.modules), "kernel_dir": os.environ.get("NUMBA_CACHE_DIR")}))
"""


@pytest.mark.parametrize("argv", [["estop"], ["stop"], ["status"], ["reset"], ["move", "0", "0", "0", "0", "0", "0"]])
def test_a_control_command_imports_nothing_heavy(argv, tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}  # (as from a shell)
    r = subprocess.run([sys.executable, "-c", CHILD, *argv, "--socket", str(tmp_path / "none.sock")],
                       capture_output=True, text=True, timeout=60, env=env)
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["code"] == 6  # no daemon there: exit 6, said on stderr
    heavy = [m for m in out["modules"] if m.split(".")[0] in HEAVY or any(m.startswith(h) for h in HEAVY if "." in h)]
    assert not heavy, heavy
    assert out["kernel_dir"] is None  # nor hashed the sources to choose a kernel directory (rtctl.kernel_cache)


def test_importing_numba_after_rtctl_chooses_the_kernel_directory_first():
    """The other half of the lazy choice: a process that compiles gets its kernel directory
    before numba reads its settings, whichever module imports numba first."""
    code = ("import os, rtctl; assert 'NUMBA_CACHE_DIR' not in os.environ; import numba.core.config as c; "
            "print(os.environ['NUMBA_CACHE_DIR'], c.CACHE_DIR)")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    chosen, numba_sees = r.stdout.split()
    assert "rtctl-kernels-" in chosen and numba_sees == chosen
