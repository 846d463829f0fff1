import pytest

from hil_helpers import HilSim
from runtime_helpers import write_config  # noqa: F401  (fixture)


@pytest.fixture
def hil_sim():
    """Start ``hil-sim`` processes; each is killed at teardown if the test left it running."""
    started = []

    def start(config, *args):
        sim = HilSim(config, *args)
        started.append(sim)
        return sim

    yield start
    for sim in started:
        sim.kill()
