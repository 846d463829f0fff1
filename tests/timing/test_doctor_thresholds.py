"""The doctor's two thresholds, as docs/operations.md states them: a timer slack above 1 µs
warns, and so does a deepest idle state that takes more than 10 µs to exit."""
import pytest

from rtctl.timing import doctor as d


@pytest.mark.parametrize("slack_ns, status", [(1, d.OK), (1000, d.OK), (1001, d.WARN)])
def test_a_timer_slack_above_one_microsecond_warns(slack_ns, status):
    assert d.check_timer_slack(slack_ns).status == status


@pytest.mark.parametrize("deepest_us, status", [(10, d.OK), (11, d.WARN)])
def test_an_idle_state_exiting_in_more_than_ten_microseconds_warns(deepest_us, status):
    assert d.check_cpuidle("intel_idle", {"POLL": 0, "C1": 2, "C6": deepest_us}).status == status
