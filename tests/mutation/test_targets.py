"""The mutation targets' test lists hold every test written for their survivors: a
``test_<target>_survivors*.py`` outside its target's list would never run against the mutants
it was written for, and each rerun would report them alive."""
from pathlib import Path

import pytest

from targets import TARGETS

TESTS = Path(__file__).parents[1]
SURVIVOR_FILES = sorted(TESTS.glob("*/test_*_survivors*.py"))


def _target_of(path: Path) -> str:
    return path.stem.removeprefix("test_").split("_survivors")[0]


def test_there_are_survivor_files_to_check():
    assert len(SURVIVOR_FILES) > 10


@pytest.mark.parametrize("path", SURVIVOR_FILES, ids=lambda p: p.name)
def test_a_survivor_file_is_in_its_targets_tests(path):
    name = _target_of(path)
    assert name in TARGETS, f"{path.name}: no mutation target {name!r}"
    listed = [TESTS.parent / t for t in TARGETS[name][1].split()]
    assert any(path == t or t in path.parents for t in listed), \
        f"{path.relative_to(TESTS.parent)} is not among target {name!r}'s tests: {TARGETS[name][1]}"
