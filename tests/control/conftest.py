"""Fixtures of the controller tests: the robots of the model tests (PUMA 560, the two-link arm,
random chains with prismatic joints, from tests/model/conftest.py) and closed-loop helpers."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from rtctl.model import load_robot

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "configs" / "robots"

_spec = importlib.util.spec_from_file_location("model_test_robots", ROOT / "tests" / "model" / "conftest.py")
_model_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_model_fixtures)
make_random_chain = _model_fixtures.make_random_chain
random_params = _model_fixtures.random_params


@pytest.fixture(scope="session")
def puma():
    return load_robot(ROBOTS / "puma560.toml")


@pytest.fixture(scope="session")
def two_link():
    return load_robot(ROBOTS / "two_link.toml")


@pytest.fixture(scope="session")
def random_chain():
    return make_random_chain
