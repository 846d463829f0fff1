"""`rtctl bench grabber` runs and reports every row (its timings are goals, not asserted)."""
from runtime_helpers import rtctl


def test_bench_grabber_prints_its_table(tmp_path):
    out = tmp_path / "grabber.json"
    r = rtctl("bench", "grabber", "--json", out, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    for row in ("take newest 512×512", "unpack 1/2/4-bit, worst", "marker: observer per image", "13 MB/s",
                "simulator: a whole field", "lock-step at 1 kHz"):
        assert row in r.stdout
    assert out.exists()
