"""Issue 26 item 6: hil-sim's listen address — a port out of range, one in use, an address that
is not this machine's or does not resolve — is an exit 2 with the reason, not a traceback."""
from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from runtime_helpers import ROOT



@pytest.mark.parametrize("args, words", [
    (["--port", "99999"], "--port must be a TCP port, 0–65535"),
    (["--port", "-1"], "--port must be a TCP port, 0–65535"),
    (["--host", "192.0.2.1", "--port", "0"], "cannot listen on 192.0.2.1:0"),  # not this machine's
    (["--host", "nonexistent.invalid", "--port", "0"], "cannot listen on nonexistent.invalid:0"),
    (["--port", "{busy}"], "another hil-sim on that port?"),
])
def test_hil_sim_listen_address_errors_exit_2_with_the_reason(args, words):
    """Issue 26 item 6: each of these was a traceback."""
    with socket.create_server(("127.0.0.1", 0)) as busy:
        args = [a.format(busy=busy.getsockname()[1]) for a in args]
        r = subprocess.run([sys.executable, "-m", "hil_sim.cli", str(ROOT / "configs" / "puma560_hil_socketcand.toml"),
                            *args], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, r.stderr[-2000:]
