"""Parameters that may change while the robot runs (``rtctl get`` / ``rtctl set``).

A controller lists its tunable parameters in :meth:`~rtctl.control.base.Controller.tunables`:
name → :class:`Tunable`, whose ``read`` is the very reader its ``from_config`` uses, so a value
set at run time passes the checks a configuration file's value passes (range, finiteness,
shape) and fails with the same message. What is not listed cannot change at run time: the
robot model, the device layout, the loop rate, a controller's law or its structure.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rtctl.tomltable import Table

SOURCE = "<rtctl set>"  # the "file" a run-time value comes from, in error messages


@dataclass(frozen=True)
class Tunable:
    value: np.ndarray  # what the controller reads, changed in place (a view the telemetry records)
    read: Callable[[Table, str], np.ndarray]  # (table, key) → the checked value, as in the config file
    apply: Callable[[np.ndarray], None] | None = None  # when one setting feeds several arrays

    def set(self, new: np.ndarray) -> None:
        if self.apply is not None:
            self.apply(new)
        else:
            np.copyto(self.value, new)


def read_value(tunable: Tunable, owner: str, key: str, raw) -> np.ndarray:
    """``raw`` (a number or a list, as in TOML) checked by the parameter's own reader; a
    :class:`~rtctl.errors.ConfigError` naming ``owner.key`` otherwise."""
    table = Table({key: raw}, SOURCE, owner)
    return np.broadcast_to(tunable.read(table, key), tunable.value.shape)
