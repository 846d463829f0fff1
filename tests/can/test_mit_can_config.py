"""The mit_can device's settings as a run's configuration gives them (MitCanJointGroup.from_config,
in-process: it validates and opens nothing)."""
import inspect
from types import SimpleNamespace

import pytest

from drivers.can_joints import MitCanJointGroup
from rtctl.config import LoopConfig
from rtctl.errors import BusLoadError, ConfigError
from rtctl.tomltable import Table

TIMING = ("reply_deadline", "stale_limit", "drive_timeout", "exchange_timeout", "reconnect_timeout",
          "reconnect_interval")


def from_config(**options):
    t = Table({"bus": {"interface": "virtual", "channel": "x", "bitrate": 1_000_000}, **options}, "run.toml", "devices[0]")
    device = SimpleNamespace(name="arm", options=t, joints=[0, 1])
    context = SimpleNamespace(model=SimpleNamespace(joint_names=["a", "b"]), period=0.001, shared={})
    return MitCanJointGroup.from_config(device, context)


def timing(group) -> dict:
    return {"reply_deadline": group.reply_timeout / 0.001, "stale_limit": group.stale_limit,
            "drive_timeout": group.drive_timeout, "exchange_timeout": group.exchange_timeout,
            "reconnect_timeout": group.reconnect_timeout, "reconnect_interval": group.reconnect_interval}


def test_without_settings_a_device_has_the_drivers_defaults_and_each_is_a_value_it_accepts():
    defaults = timing(from_config())
    constructor = inspect.signature(MitCanJointGroup.__init__).parameters
    assert defaults == pytest.approx({key: constructor[key].default for key in TIMING}, rel=1e-12)
    assert timing(from_config(**defaults)) == pytest.approx(defaults, rel=1e-12)  # written out, they pass
    assert from_config().set_zero_at_configure is constructor["set_zero"].default is False  # never unasked
    assert constructor["period"].default == 1 / LoopConfig.rate_hz  # built without a configuration: the loop's


@pytest.mark.parametrize("key, accepted, refused", [
    ("stale_limit", [1, 10_000], [0, 10_001]),
    ("reply_deadline", [0.01, 0.95], [0.0, 0.951]),
    ("exchange_timeout", [60.0], [0.0, 60.001]),
    ("drive_timeout", [10.0], [0.0, 10.001]),
    ("reconnect_interval", [10.0], [0.0, 10.001]),
    ("reconnect_timeout", [0.0, 60.0], [-0.001, 60.001]),
])
def test_timing_settings_are_refused_just_past_their_bounds(key, accepted, refused):
    for value in accepted:
        from_config(**{key: value})
    for value in refused:
        with pytest.raises(ConfigError) as e:
            from_config(**{key: value})
        assert e.value.key_path == f"devices[0].{key}"


def test_the_bus_load_limit_is_a_fraction_of_the_bus():
    from_config(bus_load_limit=1.0)
    for bad in (0.0, -0.5, 1.01):
        with pytest.raises(ConfigError) as e:
            from_config(bus_load_limit=bad)
        assert e.value.key_path == "devices[0].bus_load_limit"
    with pytest.raises(BusLoadError):  # two MIT joints at 1 kHz are 50 % of 1 Mbit/s
        from_config(bus_load_limit=0.49)
