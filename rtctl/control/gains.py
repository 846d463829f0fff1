"""Reading per-joint gains from a controller's configuration table."""
from __future__ import annotations

import numpy as np


def per_joint(t, key: str, n: int, default=None, *, min=0.0) -> np.ndarray:
    """A gain given as one number (all joints) or an array of ``n`` numbers, each finite and ≥ ``min``."""
    value = t.raw(key, default)
    if value is None:
        raise t.error(key, f"missing; expected a number or an array of {n} numbers")
    if isinstance(value, list):
        return t.vector(key, n, min=min)
    return np.full(n, t.float(key, default, min=min))
