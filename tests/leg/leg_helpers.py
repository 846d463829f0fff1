"""Paths and shared helpers of the leg tests (a uniquely named module: see tests/model)."""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TABLE3 = ROOT / "configs" / "leg" / "table3.toml"
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
from runtime_helpers import rtctl  # noqa: E402,F401  (re-exported)
