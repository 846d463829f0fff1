"""Reading per-joint gains from a controller's configuration table."""
from __future__ import annotations

import numpy as np


def per_joint(t, key: str, n: int, default=None, *, min=0.0) -> np.ndarray:
    """A gain given as one number (all joints) or an array of ``n`` numbers."""
    value = t.raw(key, default)
    if value is None:
        raise t.error(key, f"missing; expected a number or an array of {n} numbers")
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        arr = np.full(n, float(value))
    else:
        arr = t.vector(key, n)
    if np.any(arr < min):
        raise t.error(key, f"numbers ≥ {min}, got {value!r}")
    return arr
