"""A controller built in Python without an option gets what a configuration that leaves the
option out gets (rtctl.config's controller table): one default, not two that can drift apart."""
from __future__ import annotations

import inspect

import pytest

from rtctl.config import _controllers
from rtctl.control import CONTROLLERS, Controller, controller_class
from rtctl.tomltable import Table


def test_every_controller_runs_every_tick_unless_told_otherwise(puma):
    table = Table({"controllers": [{"name": "c", "type": "pd_gravity"}]}, "run.toml", "")
    (cfg,) = _controllers(table, puma)
    classes = [Controller, *(controller_class(t) for t in CONTROLLERS)]
    defaults = {cls.__name__: inspect.signature(cls.__init__).parameters["divisor"].default for cls in classes}
    assert defaults == {cls.__name__: cfg.divisor for cls in classes} and cfg.divisor == 1


@pytest.mark.parametrize("missing", ["lam", "kd", "gamma"])
def test_slotine_li_has_no_default_gain_a_configuration_lacks(puma, missing):
    from rtctl.control.slotine_li import SlotineLi

    with pytest.raises(TypeError, match=missing):
        SlotineLi(puma, **{k: 5.0 for k in ("lam", "kd", "gamma") if k != missing})


def test_the_drive_train_feed_forward_smooths_coulomb_friction_as_the_simulated_plant_does():
    """The feed-forward cancels the plant's friction only with the plant's own tanh(q̇ / v_c):
    0.01 rad/s (docs/mujoco.md), by default in both."""
    from hil_sim.plant import Plant
    from rtctl.control.computed_torque import ComputedTorque
    from rtctl.control.slotine_li import SlotineLi

    v_c = {cls.__name__: inspect.signature(cls.__init__).parameters["coulomb_velocity"].default
           for cls in (ComputedTorque, SlotineLi, Plant)}
    assert v_c == {"ComputedTorque": 0.01, "SlotineLi": 0.01, "Plant": 0.01}
