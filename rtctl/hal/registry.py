"""Lazy driver registry through the entry-point group ``rtctl.drivers`` (python-can's
``can.interface`` pattern): ``rtctl`` never imports ``drivers`` or ``hil_sim``; the
configuration names a driver and the registry imports it on first use."""
from __future__ import annotations

from functools import cache
from importlib.metadata import entry_points

from rtctl.errors import DriverNotFoundError

GROUP = "rtctl.drivers"


@cache
def _entry_points() -> dict:
    return {ep.name: ep for ep in entry_points(group=GROUP)}


def available_drivers() -> list[str]:
    return sorted(_entry_points())


def load_driver(name: str):
    """The driver class registered as ``name``; it has ``from_config(table, context)``."""
    ep = _entry_points().get(name)
    if ep is None:
        raise DriverNotFoundError(
            f"no driver named {name!r} in entry-point group {GROUP!r}; "
            f"installed: {', '.join(available_drivers()) or 'none'} (is the package installed?)"
        )
    return ep.load()
