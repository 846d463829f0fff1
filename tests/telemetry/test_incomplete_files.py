"""Issue 26 items 4 and 8: a telemetry file a daemon left unfinished (a header only, or cut
inside a record) gets a clear exit 2 from `plot`, `identify` and `export`, or is read with a
note of how many rows; `identify` bounds its model orders and options before it allocates."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import msgpack
import pytest

from test_plot import synthetic_run

ROOT = Path(__file__).resolve().parents[2]


def rtctl(*args):
    return subprocess.run([sys.executable, "-m", "rtctl.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("tel")
    whole = d / "whole.msgpack"
    synthetic_run(whole, n=3000)
    data = whole.read_bytes()
    unpacker = msgpack.Unpacker(raw=False, strict_map_key=False)
    unpacker.feed(data)
    next(unpacker)  # the header
    (d / "header_only.msgpack").write_bytes(data[:unpacker.tell()])
    (d / "cut.msgpack").write_bytes(data[:len(data) * 2 // 3])
    return d


@pytest.mark.parametrize("command, what", [
    (["plot", "{f}", "-o", "{d}/p.png"], "plot"),
    (["identify", "{f}"], "identify"),
    (["export", "{f}", "--mcap", "{d}/x.mcap"], "export"),
])
def test_a_header_only_file_is_nothing_to_read_and_says_why(files, command, what):
    if what == "plot":
        pytest.importorskip("matplotlib")
    if what == "export":
        pytest.importorskip("mcap")
    f = files / "header_only.msgpack"
    result = rtctl(*(a.format(f=f, d=files) for a in command))
    assert result.returncode == 2, result.stderr
    assert f"nothing to {what}: 0 rows recorded" in result.stderr and "no footer" in result.stderr
    assert "Traceback" not in result.stderr


def test_identify_of_a_cut_file_says_so_and_how_many_rows_it_read(files):
    result = rtctl("identify", files / "cut.msgpack", "--period", 0.01)
    assert result.returncode == 0, result.stderr
    head, note = result.stdout.splitlines()[:2]
    rows = int(head.split(" samples of ")[1].split()[0])
    assert 0 < rows < 3000 and note == f"note: the file ends inside a record (a crash while writing): {rows} complete rows read"
    whole = rtctl("identify", files / "whole.msgpack", "--period", 0.01)
    assert "note:" not in whole.stdout and "300 samples of 3000 recorded rows" in whole.stdout


@pytest.mark.parametrize("option, value", [("--na", 100000), ("--nb", 0), ("--d", 65), ("--lam", 1.5),
                                           ("--period", -0.02), ("--p0", 0), ("--r0", -1)])
def test_identify_refuses_an_option_out_of_bounds_naming_it(files, option, value):
    result = rtctl("identify", files / "whole.msgpack", option, value)
    assert result.returncode == 2 and f"<command line>: {option}: " in result.stderr, result.stderr
