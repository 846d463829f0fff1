"""Tests for control mutants that survived the fast pass of the run over every mutant, resumed
again in two shards (docs/mutation/control.md), part 8:

* a Slotine–Li configuration that leaves its options out gets the documented defaults: the
  C* law, no projection, no dead zone, no drive-train model;
* ARMA/GMV: a drift mean q̂ (26) that overflowed while θ̂, P, r̂ and R̂ stayed finite is named as
  the drift mean (a check of the wrong row named it the drift covariance Q̂).
"""
import itertools
import sys
from pathlib import Path

import numpy as np

from rtctl.config import load_config
from rtctl.control.slotine_li import LAWS
from rtctl.errors import ControllerError
from rtctl.runtime import build

sys.path.insert(0, str(Path(__file__).parent))
from test_config import configured  # noqa: E402 (the shipped C* job with lam, kd, gamma only)
from test_control_survivors import _primed  # noqa: E402 (the shipped ARMA/GMV job, one update made)


def test_slotine_li_options_left_out_get_the_documented_defaults(tmp_path):
    (c,) = build(load_config(configured(tmp_path, ""))).controllers
    assert c.law == "cstar" and "cstar" in LAWS
    assert not c.projection and c.dead_zone == 0.0
    assert not c.motor_model  # "motor_model = true adds the robot file's armature …"


def test_a_drift_mean_that_overflowed_alone_is_named(tmp_path):
    """q̂(k+1) = (1 − d_k) q̂ + d_k (q̂ + K ε) overflows where θ̂(k+1|k+1) = θ̂ + q̂ + K ε does not
    (θ̂ = −q̂ ≈ −max float, a huge y making K ε large): the fault names q̂. Which coefficient,
    sign and y reach that state depends on the regressor, so every case of the grid where the
    update left q̂ alone non-finite must name it, and at least one case must."""
    named = []
    for a, sign, y in itertools.product(range(5), (1.0, -1.0), (1e306, 1e307)):
        c, state, ref, cmd = _primed(tmp_path, adapt="{ r = false, R = false, q = true, Q = false }")
        f = c.filter
        f.P[1] = 1e4 * np.eye(f.P.shape[1])  # a large gain K
        f.theta[a, 1], f.q_hat[a, 1] = -sign * 1.7976e308, sign * 1.7976e308
        state.position[1] = y
        try:
            c.update(0.02, state, ref, cmd)
            continue
        except ControllerError as e:
            message = str(e)
        others_finite = (np.isfinite(f.theta[:, 1]).all() and np.isfinite(f.P[1]).all()
                         and np.isfinite(f.signals[:2, 1]).all())
        if others_finite and not np.isfinite(f.q_hat[:, 1]).all():
            named.append(message)
    assert named and all(m == "joint 'shoulder': non-finite drift mean q̂" for m in named), named
