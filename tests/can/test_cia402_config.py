"""The cia402 device's settings as a run's configuration gives them (Cia402JointGroup.from_config,
in-process: it validates and opens nothing) — the defaults docs/cia402.md lists, the bounds the
MIT driver shares (tests/can/test_mit_can_config.py), and the bus budget at the loop rate."""
import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from drivers.cia402_joints import Cia402JointGroup
from rtctl.config import LoopConfig
from rtctl.errors import BusLoadError, ConfigError
from rtctl.tomltable import Table

PERIOD = 0.001


def from_config(shared=None, **options):
    t = Table({"bus": {"interface": "virtual", "channel": "x", "bitrate": 1_000_000}, "rated_torque": 10.0,
               **options}, "run.toml", "devices[0]")
    device = SimpleNamespace(name="arm", options=t, joints=[0, 1])
    model = SimpleNamespace(joint_names=["a", "b"], tau_max=np.array([5.0, 5.0]))
    context = SimpleNamespace(model=model, period=PERIOD, shared={} if shared is None else shared)
    return Cia402JointGroup.from_config(device, context)


def test_without_settings_a_device_has_the_documented_defaults():
    g = from_config()  # docs/cia402.md's example block, and the driver's module docstring
    assert g.reply_timeout == pytest.approx(0.6 * PERIOD, rel=1e-12)
    assert g.stale_limit == 3 and g.drive_timeout == 0.02 and g.exchange_timeout == 0.5
    assert g.heartbeat_period == 0.1 and g.heartbeat_timeout == pytest.approx(0.3, rel=1e-12)
    assert g.reconnect_timeout == 2.0 and g.reconnect_interval == 0.05
    constructor = inspect.signature(Cia402JointGroup.__init__).parameters  # built without a configuration: the same
    assert {k: constructor[k].default for k in ("reply_deadline", "stale_limit", "drive_timeout", "heartbeat_period",
                                                "exchange_timeout", "reconnect_timeout", "reconnect_interval",
                                                "period")} == {
        "reply_deadline": 0.6, "stale_limit": 3, "drive_timeout": 0.02, "heartbeat_period": 0.1,
        "exchange_timeout": 0.5, "reconnect_timeout": 2.0, "reconnect_interval": 0.05,
        "period": 1 / LoopConfig.rate_hz}  # (the loop's default rate)


@pytest.mark.parametrize("key, accepted, refused", [
    ("stale_limit", [1], [0]),  # one missed tick may already be an error
    ("reconnect_timeout", [0.0], [-0.001]),  # 0: no reopening, the device stays ERROR at once
    ("reply_deadline", [0.95], [0.0, 0.951]),
    ("drive_timeout", [0.001, 65.535], [0.0, -0.02, 65.536]),  # 0x1400 sub 5: UNSIGNED16 ms, 0 = none
    ("heartbeat_period", [0.001, 65.535], [0.0, 65.536]),  # 0x1017: UNSIGNED16 ms, 0 = none
    ("reconnect_interval", [0.001], [0.0]),
    ("exchange_timeout", [0.001], [0.0, -0.5]),  # SDO answers and the state machine need time to come
    ("bus_load_limit", [1.0], [0.0, 1.01]),  # a fraction of the bus
])
def test_settings_at_their_bounds(key, accepted, refused):
    for value in accepted:
        from_config(**{key: value})
    for value in refused:
        with pytest.raises(ConfigError) as e:
            from_config(**{key: value})
        assert e.value.key_path == f"devices[0].{key}"


def test_the_bus_budget_is_taken_at_the_loop_rate():
    """Two joints at 1 kHz on 1 Mbit/s: per joint RPDO1 (4 B), TPDO1 (8 B), TPDO2 (4 B), per bus one
    SYNC (0 B), each frame at its worst-case stuffed length 8n + 47 + ⌊(34 + 8n − 1)/4⌋ bits
    (ISO 11898-1) — 705 bits per tick, 70.5 % of the bus at 1000 ticks a second."""
    def bits(n):
        return 8 * n + 47 + (34 + 8 * n - 1) // 4

    load = (2 * (bits(4) + bits(8) + bits(4)) + bits(0)) / PERIOD / 1_000_000
    assert load == pytest.approx(0.705)
    from_config(bus_load_limit=load)  # exactly at the limit: accepted
    with pytest.raises(BusLoadError):
        from_config(bus_load_limit=load - 1e-4)


def test_the_first_device_of_a_run_reports_the_bus_budget():
    """BusBudget.of: the run's budget is reported by the device that created it — once."""
    shared = {}
    first = from_config(shared)
    second = from_config(shared, bus={"interface": "virtual", "channel": "y", "bitrate": 1_000_000})
    assert first.budget is not None and second.budget is None
    assert sorted(b.label for b in first.budget.buses.values()) == ["x", "y"]  # (both buses in it)


def test_a_second_cia402_device_on_the_same_bus_is_refused():
    """CANopen allows one SYNC producer per network, and each cia402 device is one (docs/cia402.md):
    a second device on the same bus is a configuration error naming its ``bus``; on another bus it is fine."""
    shared = {}
    from_config(shared)
    with pytest.raises(ConfigError) as e:
        from_config(shared)
    assert e.value.key_path == "devices[0].bus" and "SYNC" in str(e.value)  # (the SYNC rule, checked before the load both would exceed)
    assert not isinstance(e.value, BusLoadError)
    from_config(shared, bus={"interface": "virtual", "channel": "y", "bitrate": 1_000_000})
