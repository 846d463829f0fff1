"""sample() writes into the caller's arrays and allocates nothing per call."""
import itertools

import numpy as np

from allocations import growth_and_peak
from rtctl.trajectory import JointLimits, through_waypoints


def test_sample_allocates_nothing():
    # many joints, so any temporary array (≥ 200 × 8 bytes) would stand out from the few
    # hundred bytes of transient argument tuples in numba's dispatcher
    n = 200
    rng = np.random.default_rng(0)
    lim = JointLimits(np.full(n, 1.0), np.full(n, 2.0))
    tr = through_waypoints(rng.uniform(-1, 1, (4, n)), lim, smooth=True)
    q, qd, qdd = np.empty(n), np.empty(n), np.empty(n)
    ts = [float(t) for t in np.linspace(tr.t_start - 0.1, tr.t_end + 0.1, 5000)]
    tr.sample(ts[0], q, qd, qdd)
    times = itertools.cycle(ts)
    growth, peak = growth_and_peak(lambda: tr.sample(next(times), q, qd, qdd), len(ts))
    assert growth <= 64
    assert peak < 8 * n
