"""Telemetry: per-tick columns recorded off the hot path into one msgpack file per run.

``Recorder`` (the loop's side, :mod:`rtctl.telemetry.recorder`) and ``read`` (back to numpy,
:mod:`rtctl.telemetry.reader`); the file format is described in :mod:`rtctl.telemetry.schema`.
"""
from rtctl.telemetry.reader import Telemetry, read
from rtctl.telemetry.recorder import Recorder

__all__ = ["Recorder", "Telemetry", "read"]
