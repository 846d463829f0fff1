"""Session-wide.

* The default control socket of every daemon a test starts without ``--socket`` is private to
  this test session ($XDG_RUNTIME_DIR/rtctl.sock), so a user's daemon, or another test session
  on the same machine, never answers for it — or refuses it the path.
* Under pytest-xdist (``-n``, in pyproject's addopts) the real-time tests run one at a time, on
  one worker: two paced loops side by side on a 2-core machine miss their deadlines. A module
  whose tests pace a loop by the wall clock (a daemon, hil-sim, a cell) says so with
  ``pytestmark = pytest.mark.realtime``; every test in tests/hil is one. The other tests share
  the other workers a module at a time (a module's fixtures are built once).
"""
import os
import tempfile

import pytest

os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="rtctl-tests-")


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups, and before -m selects
def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.parent.name == "hil":
            item.add_marker(pytest.mark.realtime)
        group = "realtime" if item.get_closest_marker("realtime") else item.nodeid.split("::")[0]
        item.add_marker(pytest.mark.xdist_group(group))


def pytest_collection_finish(session):
    """A pytest-xdist that stopped grouping (as with pytest 9.2, pytest-xdist#1386) would run
    paced loops side by side and fail at random: refuse the run instead."""
    if getattr(session.config.option, "loadgroup", False):  # (set on the workers of --dist loadgroup)
        loose = [i.nodeid for i in session.items if i.get_closest_marker("realtime") and "@realtime" not in i.nodeid]
        if loose:
            raise pytest.UsageError(f"pytest-xdist did not put {loose[0]} (and {len(loose) - 1} more) into the "
                                    f"realtime group: use a pytest it supports (pyproject.toml) or run with -n 0")
