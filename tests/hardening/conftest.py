"""Regression tests of the hardening issue (one per defect, named after it) and the bounded
fuzzers that keep such defects out. The runtime tests' helpers (configs, a daemon subprocess)
are shared."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from rtctl.model import load_robot

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
sys.path.insert(0, str(ROOT / "tests" / "model"))  # random_robots

from runtime_helpers import daemon, write_config  # noqa: E402,F401  (fixtures)


@pytest.fixture(scope="session")
def puma():
    return load_robot(ROOT / "configs" / "robots" / "puma560.toml")
