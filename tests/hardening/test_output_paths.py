"""Issue 26 item 7: every subcommand that writes a file, against every kind of path it cannot
write — a directory, a path under a file, a pseudo file system (/sys) — exits 2 naming its
option (or the telemetry file), before doing its work, without a traceback."""
from __future__ import annotations

import subprocess
import sys

import pytest

from runtime_helpers import ROOT

GUARD = ROOT / "configs" / "puma560_guard_sim.toml"
VISION = ROOT / "configs" / "puma560_vision_sim.toml"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    path = d / "run.msgpack"
    r = subprocess.run([sys.executable, "-m", "rtctl.cli", "run", str(ROOT / "configs" / "puma560_sim.toml"),
                        "--duration", "0.2", "--realtime-factor", "0", "--telemetry", str(path),
                        "--socket", str(d / "s.sock")], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    return path


WRITERS = {  # subcommand → (arguments with {out} for the path, what the message names)
    "run --summary": (["run", ROOT / "configs" / "puma560_sim.toml", "--duration", "0.1", "--socket", "{tmp}/s.sock",
                       "--summary", "{out}"], "--summary"),
    "run --telemetry": (["run", ROOT / "configs" / "puma560_sim.toml", "--duration", "0.1", "--socket", "{tmp}/s.sock",
                         "--telemetry", "{out}"], "telemetry"),
    "plan --plot": (["plan", GUARD, "--to", 0, 180, -60, 0, 30, 0, "--deg", "--plot", "{out}"], "--plot"),
    "plot -o": (["plot", "{rec}", "-o", "{out}"], "--output"),
    "export --mcap": (["export", "{rec}", "--mcap", "{out}"], "--mcap"),
    "identify --json": (["identify", "{rec}", "--json", "{out}"], "--json"),
    "grab -o": (["grab", VISION, "--sim", "-o", "{out}"], "--output"),
}
BAD = {
    "a directory": lambda tmp: tmp,
    "a path under a file": lambda tmp: tmp / "a_file" / "out.png",
    "a pseudo file system": lambda tmp: "/sys/rtctl-out.png",
}


@pytest.mark.parametrize("bad", BAD)
@pytest.mark.parametrize("writer", WRITERS)
def test_every_file_writing_subcommand_refuses_a_path_it_cannot_write(writer, bad, recording, tmp_path):
    (tmp_path / "a_file").write_text("")
    args, names = WRITERS[writer]
    out = BAD[bad](tmp_path)
    argv = [str(a).format(out=out, rec=recording, tmp=tmp_path) for a in args]
    r = subprocess.run([sys.executable, "-m", "rtctl.cli", *argv], capture_output=True, text=True, timeout=300,
                       cwd=ROOT)
    if "needs" in r.stderr and "extra" in r.stderr:  # an optional writer (matplotlib, mcap, Pillow) not installed
        pytest.skip(r.stderr.strip().splitlines()[-1])
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    assert names in r.stderr and "Traceback" not in r.stderr, r.stderr[-2000:]
