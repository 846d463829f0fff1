"""The kernel census under `rtctl bench loop`: it sees the kernels a Python caller reaches through
module globals, counts their calls, times them on copies, and leaves everything as it was."""
from pathlib import Path

import numpy as np

import hil_sim.plant as plant_module
from hil_sim.plant import Plant
from rtctl.bench.kernel_census import SNAPSHOT_EVERY, KernelCensus
from rtctl.model import load_robot

PUMA = Path(__file__).resolve().parents[2] / "configs" / "robots" / "puma560.toml"


def test_census_counts_python_calls_times_them_on_copies_and_unpatches():
    plant = Plant(load_robot(PUMA), q0=np.full(6, 0.3))
    plant.tau_cmd[:] = 1.0
    plant.step(1e-3)  # compiled (or loaded) first: numba would type a patched global as a Python object
    original = plant_module.plant_step
    with KernelCensus() as census:
        assert plant_module.plant_step is not original
        for _ in range(10):
            plant.step(1e-3)
    assert plant_module.plant_step is original
    q_after_run = plant.q.copy()
    cost = census.cost_per_tick(ticks=10, samples=6)
    assert cost["kernels"]["plant_step"]["calls_per_tick"] == 1.0
    assert cost["kernels"]["plant_step"]["us_per_call"] > 0
    assert cost["total_us"] >= cost["kernels"]["plant_step"]["us_per_tick"]
    np.testing.assert_array_equal(plant.q, q_after_run)  # timed on copies, not on the run's arrays


def test_the_census_times_kernels_on_the_inputs_they_had_during_the_run():
    """Snapshots are the arguments as a call received them, spread over the run — not the last
    call's output state repeated (an adaptation law fed its own output drifts elsewhere)."""
    plant = Plant(load_robot(PUMA), q0=np.full(6, 0.3))
    plant.tau_cmd[:] = 1.0
    plant.step(1e-3)
    q_at = {}
    with KernelCensus() as census:
        for k in range(1, 3 * SNAPSHOT_EVERY + 1):
            q_at[k] = plant.q.copy()  # before call k
            plant.step(1e-3)
    counted = next(c for c in census.counted.values() if c.kernel.py_func.__name__ == "plant_step")
    assert len(counted.snapshots) == 3
    vectors = lambda snap: [v for a in snap if isinstance(a, np.ndarray) for v in (a if a.ndim == 2 else [a])]
    for i, snap in enumerate(counted.snapshots):
        assert any(np.array_equal(q_at[(i + 1) * SNAPSHOT_EVERY], v) for v in vectors(snap)), i
