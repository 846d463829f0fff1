import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "runtime"))

from runtime_helpers import daemon, write_config  # noqa: E402,F401  (fixtures)
