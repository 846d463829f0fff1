"""Strict JSON for everything rtctl writes (logs, summary files, bench results, replies).

JSON has no NaN or Infinity; Python's ``json`` writes them anyway, and JavaScript's
``JSON.parse`` (Foxglove, web dashboards) or ``jq`` then refuse the whole document. Here a
non-finite float becomes ``null`` — what ``JSON.stringify`` does — and numpy scalars and
arrays become plain numbers and lists.
"""
from __future__ import annotations

import json
import math
import sys


def strict(obj):
    """``obj`` with every non-finite float replaced by None, numpy values made plain, tuples as lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict(v) for v in obj]
    np = sys.modules.get("numpy")  # (not imported: no numpy value can exist — the light clients never load it)
    if np is None:
        return obj
    if isinstance(obj, np.ndarray):
        return strict(obj.tolist())
    if isinstance(obj, np.generic):
        return strict(obj.item())
    return obj


def print_json(obj) -> None:
    """``obj`` on stdout as indented, strict JSON (what the CLI prints)."""
    print(dumps(obj, indent=2, sort_keys=True))


def dumps(obj, **kwargs) -> str:
    """``json.dumps`` that never writes NaN or Infinity (raises ValueError if one slipped through)."""
    return json.dumps(strict(obj), allow_nan=False, **kwargs)
