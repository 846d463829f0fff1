"""A mutant is killed only by a failure that happens again (tests/mutation/mutant_tests.py,
``confirmed_status``): a test that a loaded machine fails now and then must not kill an
equivalent mutant. Real pytest runs on a small test file; nothing here runs a mutant."""
from __future__ import annotations

import sys
import textwrap

import pytest

from mutant_tests import NOT_REPRODUCED, PYTEST, confirmed_status, first_failure, run_tests

TESTS = """
from pathlib import Path

def test_passes():
    pass

def test_fails_the_first_time():
    marker = Path(__file__).with_name("failed_once")
    if not marker.exists():
        marker.write_text("")
        assert False, "a stall"

def test_always_fails():
    assert 1 == 2

def test_last():
    pass
"""


@pytest.fixture
def tests_here(tmp_path, monkeypatch):
    (tmp_path / "test_sample.py").write_text(textwrap.dedent(TESTS))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_a_failure_that_passes_when_run_again_is_not_a_kill(tests_here, capfd):
    rc, failure = confirmed_status(PYTEST + ["test_sample.py::test_passes", "test_sample.py::test_fails_the_first_time",
                                             "test_sample.py::test_last"], 60.0)
    assert (rc, failure) == (0, "not reproduced")
    assert f"{NOT_REPRODUCED}: test_sample.py::test_fails_the_first_time" in capfd.readouterr().out


def test_a_failure_that_happens_again_is_a_kill(tests_here):
    assert confirmed_status(PYTEST + ["test_sample.py::test_passes", "test_sample.py::test_always_fails"],
                            60.0) == (1, "reproduced")


def test_a_pass_and_a_time_out_are_taken_as_they_are(tests_here, capfd):
    assert confirmed_status(PYTEST + ["test_sample.py::test_passes"], 60.0) == (0, None)
    hang = [sys.executable, "-c", "import time; time.sleep(60)"]
    assert confirmed_status(hang, 1.0) == (1, None)  # (no test named: a time-out is not run again)
    assert "MUTATION-TIMED-OUT" in capfd.readouterr().out


def test_a_failure_that_passes_alone_but_fails_in_order_is_still_a_kill():
    """Alone, the first failed test passes (it needed an earlier test's state); all the tests
    again decide, and they fail again."""
    calls = []

    def run(argv, limit_s, output=None):
        calls.append(argv)
        if output is not None:
            output += ["F", "FAILED tests/test_a.py::test_b[x-1] - assert 0", "1 failed"]
        return 0 if argv == PYTEST + ["tests/test_a.py::test_b[x-1]"] else 1

    assert confirmed_status(["all"], 1.0, run=run) == (1, "not reproduced")
    assert calls == [["all"], PYTEST + ["tests/test_a.py::test_b[x-1]"], ["all"]]


@pytest.mark.parametrize("lines, failing", [
    (["....F", "FAILED tests/hil/test_x.py::test_rate[fields-50.0-0.02] - assert 1 == 0"],
     "tests/hil/test_x.py::test_rate[fields-50.0-0.02]"),
    (["ERROR tests/a.py::test_b - RuntimeError: fixture"], "tests/a.py::test_b"),
    (["FAILED tests/a.py::test_c"], "tests/a.py::test_c"),
    (["ERROR tests/a.py - ImportError"], None),  # (a collection error: no test to run again)
    (["1 passed"], None),
])
def test_the_first_failed_test_is_read_from_pytests_summary(lines, failing):
    assert first_failure(lines) == failing


def test_the_tests_output_is_passed_on_and_kept(capfd):
    lines: list[str] = []
    assert run_tests([sys.executable, "-c", "print('one'); print('two')"], 30.0, lines) == 0
    assert lines == ["one", "two"] and capfd.readouterr().out == "one\ntwo\n"
