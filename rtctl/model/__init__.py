"""Robot model: spatial algebra, descriptions, kinematics and dynamics.

Pure functions over (model, state); see :mod:`rtctl.model.robot` for the conventions.
"""
from __future__ import annotations

from pathlib import Path

from rtctl.errors import ConfigError
from rtctl.model.robot import PRISMATIC, REVOLUTE, Model


def load_robot(path) -> Model:
    """A Model from a D-H TOML table (``.toml``) or a URDF file (``.urdf``)."""
    path = Path(path)
    if path.suffix == ".urdf":
        from rtctl.model.urdf import load_urdf

        return load_urdf(path)
    if path.suffix == ".toml":
        from rtctl.model.dh import from_table
        from rtctl.tomltable import load_toml

        return from_table(load_toml(path))
    raise ConfigError(path, "", "not a robot description: the name must end in .toml (D-H table) or .urdf")


__all__ = ["Model", "REVOLUTE", "PRISMATIC", "load_robot"]
