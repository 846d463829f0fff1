"""The HIL suite's own machinery: config variants refuse settings that would not apply, and a
failed bound is retried only when the run's record shows a machine stall."""
import pytest

from hil_helpers import VmStall, stall_in, unless_stalled, variant


def test_variant_sets_existing_keys_and_refuses_missing_ones(tmp_path):
    text = variant(tmp_path, "three_joint_slcan.toml", stale_ticks=10, drive_timeout=0.1).read_text()
    assert "stale_ticks = 10" in text and "drive_timeout = 0.1" in text
    with pytest.raises(KeyError, match="no no_such_key"):
        variant(tmp_path, "three_joint_slcan.toml", no_such_key=1)


def summary(overruns=0, late_us=10.0, missing=0, late_replies=0, dropped_rows=0):
    return {"timing": {"overruns": overruns, "period_us": 2000.0, "wake_lateness_us": {"max": late_us}},
            "devices": {"arm": {"counters": {"missing_replies": missing}}, "other": {},
                        "board": {"late_replies": late_replies}},  # (the leg board's counts are not nested)
            "telemetry": {"rows": 1500, "dropped_rows": dropped_rows}}


@pytest.mark.parametrize("run, stalled", [
    (summary(), None),
    (summary(late_us=999.0), None),
    (summary(overruns=2), "2 overrun(s)"),
    (summary(late_us=1500.0), "a wake-up 1500 µs late"),
    (summary(missing=3), "3 missing or late repl(ies)"),
    (summary(late_replies=8), "8 missing or late repl(ies)"),  # the MuJoCo leg's simulator starved (CI, 2026-12-04)
    (summary(dropped_rows=40), "40 telemetry row(s) dropped"),  # (its rows can hold an image's every row)
    (summary(overruns=1, dropped_rows=2), "1 overrun(s), 2 telemetry row(s) dropped"),
])
def test_a_stall_is_read_from_the_runs_own_record(run, stalled):
    assert stall_in(run) == stalled


def test_a_failed_bound_is_a_vm_stall_only_in_a_stalled_run():
    with pytest.raises(AssertionError) as quiet:
        with unless_stalled(summary()):
            assert 1 < 0
    assert not isinstance(quiet.value, VmStall)
    with pytest.raises(VmStall, match="1 overrun"):
        with unless_stalled(summary(overruns=1)):
            assert 1 < 0
    with unless_stalled(summary(overruns=1)):
        pass  # a stalled run that meets its bounds passes
