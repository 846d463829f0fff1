"""``rtctl`` with the test controllers of this directory registered (run as a subprocess)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from rtctl.cli import main  # noqa: E402
from rtctl.control import CONTROLLERS  # noqa: E402

CONTROLLERS["step_into"] = "step_controller:StepInto"

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
