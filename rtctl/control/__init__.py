"""Controllers (docs/architecture.md): one module per controller, each behind the Controller protocol.

``CONTROLLERS`` maps the configuration's ``type`` to the class; classes are imported on
first use so that a run pays only for the controllers it configures.
"""
from __future__ import annotations

from importlib import import_module

from rtctl.control.base import Controller, Reference

CONTROLLERS = {
    "pd_gravity": "rtctl.control.pd_gravity:PDGravity",
    "computed_torque": "rtctl.control.computed_torque:ComputedTorque",
    "slotine_li": "rtctl.control.slotine_li:SlotineLi",
    "arma_gmv": "rtctl.control.arma_gmv:ArmaGmv",
    "leg_automaton": "rtctl.control.leg_automaton:LegAutomaton",
    "marker_observer": "rtctl.vision.observer:MarkerObserver",  # owns no command: watches the tool marker
}


def controller_class(type_name: str):
    module, _, cls = CONTROLLERS[type_name].partition(":")
    return getattr(import_module(module), cls)


__all__ = ["Controller", "Reference", "CONTROLLERS", "controller_class"]
