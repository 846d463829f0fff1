"""Fixtures of the controller tests: the robots of the model tests (PUMA 560, the two-link arm,
random chains with prismatic joints, from tests/model/conftest.py) and closed-loop helpers."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from rtctl.model import load_robot

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "configs" / "robots"

sys.path.insert(0, str(ROOT / "tests" / "model"))
from random_robots import make_random_chain  # noqa: E402


@pytest.fixture(scope="session")
def puma():
    return load_robot(ROBOTS / "puma560.toml")


@pytest.fixture(scope="session")
def two_link():
    return load_robot(ROBOTS / "two_link.toml")


@pytest.fixture(scope="session")
def random_chain():
    return make_random_chain


@pytest.fixture(scope="session")
def puma_arm():
    return load_robot(ROBOTS / "puma560_arm.toml")
