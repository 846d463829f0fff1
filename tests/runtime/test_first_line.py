"""Issue 26 item 14: a cold `rtctl run` was silent for 4–5 s (imports, the kernel-cache probe).
Its first line must be out before anything heavy is imported — numba above all — so that the
heartbeat of the kernel warm-up takes over from there (tests/runtime/test_warmup.py)."""
from __future__ import annotations

import os
import subprocess
import sys

CHILD = """
import sys

class Watch:  # says when numba is first imported, in the same stream as the log
    seen = False

    @staticmethod
    def find_spec(name, path=None, target=None):
        if name == "numba" and not Watch.seen:
            Watch.seen = True
            print("NUMBA IMPORTED", flush=True)
        return None

sys.meta_path.insert(0, Watch)
from rtctl.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_run_says_starting_before_it_imports_numba(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    r = subprocess.run([sys.executable, "-c", CHILD, "run", str(tmp_path / "missing.toml"), "--log-format", "json"],
                       capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 2, r.stderr[-2000:]  # (the configuration is missing: exit 2, after the imports)
    lines = r.stdout.splitlines()
    first = next(i for i, line in enumerate(lines) if '"starting"' in line)
    assert "NUMBA IMPORTED" in lines and first < lines.index("NUMBA IMPORTED"), lines[:5]
