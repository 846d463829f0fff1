"""hil-sim's lock-step plant: one period per command set of the loop, counted per drive, so that
a set this process reads early on one bus (a stall, two connections) counts for the next cycle."""
from types import SimpleNamespace

from hil_sim.lockstep import PlantHub


class _Plant:
    def __init__(self):
        self.time, self.steps = 0.0, 0

    def step(self, dt):
        self.time += dt
        self.steps += 1


def _hub(*drives_per_bus):
    hub = PlantHub(_Plant(), period=0.002, emit=lambda event: None, clock=lambda: 0.0)
    for b, n in enumerate(drives_per_bus):
        drives = {i: SimpleNamespace(enabled=True, counters=SimpleNamespace(watchdog_trips=0)) for i in range(n)}
        hub.add_bus(SimpleNamespace(name=f"can{b}", drives=drives))
    return hub


def _command(hub, drives):
    for index in drives:
        hub.commanded(index, 1.0)


def test_one_cycle_per_command_set_of_every_drive():
    hub = _hub(3, 3)
    for k in range(1, 4):
        _command(hub, [0, 1, 2])
        assert hub.cycles == k - 1  # the other bus's drives still wait for theirs
        _command(hub, [3, 4, 5])
        assert hub.cycles == k and hub.plant.steps == k


def test_a_bus_read_ahead_of_the_other_counts_for_the_next_cycle():
    hub = _hub(3, 3)
    _command(hub, [0, 1, 2])  # can0, tick 1
    _command(hub, [0, 1, 2])  # can0, tick 2: read before can1's tick 1
    assert hub.cycles == 0
    _command(hub, [3, 4, 5])  # can1, tick 1
    assert hub.cycles == 1
    _command(hub, [3, 4, 5])  # can1, tick 2: completes tick 2 (can0's was already here)
    assert hub.cycles == 2 and hub.plant.steps == 2
    _command(hub, [1, 0, 3, 4, 5])  # tick 3 but one drive: no cycle yet
    assert hub.cycles == 2
    _command(hub, [2])
    assert hub.cycles == 3 and hub.plant.steps == 3
