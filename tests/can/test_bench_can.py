"""``rtctl bench can`` drives the real driver: MitCanJointGroup activated on the in-process
virtual bus answers every tick (nothing timed here: the figures are the bench's to print)."""
from rtctl.bench.can import GOALS, bench_codec, bench_virtual, format_table


def test_the_virtual_row_is_the_driver_answered_every_tick():
    row = bench_virtual(joints=2, cycles=50)
    assert row["joints"] == 2 and row["cycles"] == 50
    assert row["lost"] == 0 and row["misses"] == 0  # lock-step: every reply is there before the deadline
    assert 0 < row["median_ms"] <= row["p99_ms"] <= row["max_ms"]
    table = format_table({"codec": bench_codec(frames=100), "cycles": [row], "goals": GOALS})
    assert "MitCanJointGroup.read() + write()" in table and "virtual (lock-step, in-process)" in table
