"""Non-joint devices (framegrabber, I/O board …): configuration, binding to controllers,
lifecycle in the daemon, read/write every tick, and a failure taking their users out.

A counting device and an observer controller stand in for the real kinds; they are handed to
the runtime the way the entry-point registry would hand them.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from rtctl import runtime as runtime_mod
from rtctl.config import load_config
from rtctl.control import Controller
from rtctl.daemon import Daemon
from rtctl.errors import ConfigError, HardwareError
from rtctl.hal import Hardware, Status
from rtctl.runtime import build
from runtime_helpers import BASE


class Counter(Hardware):
    """Counts reads and writes; ``fail_from`` makes reads fail from that tick on,
    ``activations`` limits how often it can be activated (then activate() raises)."""

    instances: list = []

    def __init__(self, name, fail_from=None, deactivate_fails=False, activations=None):
        super().__init__(name)
        self.reads = self.writes = 0
        self.fail_from, self.deactivate_fails, self.activations = fail_from, deactivate_fails, activations
        self.calls: list[str] = []
        Counter.instances.append(self)

    @classmethod
    def from_config(cls, device, context):
        fail_from = device.options.int("fail_from", -1)
        deactivate_fails = device.options.bool("deactivate_fails", False)
        activations = device.options.int("activations", -1)
        device.options.done()
        return cls(device.name, None if fail_from < 0 else fail_from, deactivate_fails,
                   None if activations < 0 else activations)

    def _on_configure(self):
        self.calls.append("configure")

    def _on_activate(self):
        self.calls.append("activate")
        if self.activations is not None and self.calls.count("activate") > self.activations:
            raise HardwareError("eye: no answer to enable")

    def _on_deactivate(self):
        self.calls.append("deactivate")
        if self.deactivate_fails:
            raise HardwareError("eye: no answer to disable")

    def _on_close(self):
        self.calls.append("close")

    def _read(self, t):
        self.reads += 1
        if self.fail_from is not None and self.reads > self.fail_from:
            raise OSError("sensor cable unplugged")
        return Status.OK

    def _write(self, t):
        self.writes += 1
        return Status.OK


class Observer(Controller):
    """Owns no joint command; counts the ticks it ran and sees its device."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.updates = 0
        self.device = None

    @classmethod
    def from_config(cls, c, model):
        c.options.done()
        return cls(c.name, model, c.joints, c.divisor)

    def bind(self, devices):
        (self.device,) = devices.values()
        if not isinstance(self.device, Counter):
            raise TypeError("a counter device")

    def update(self, t, state, ref, command):
        self.updates += 1


@pytest.fixture
def registry(monkeypatch):
    drivers = {"counter": Counter, "sim_counter": Counter}
    real_load = runtime_mod.load_driver
    monkeypatch.setattr(runtime_mod, "load_driver", lambda name: drivers[name] if name in drivers else real_load(name))
    monkeypatch.setitem(runtime_mod.CONTROLLERS, "observer", "x:Observer")
    real_class = runtime_mod.controller_class
    monkeypatch.setattr(runtime_mod, "controller_class", lambda t: Observer if t == "observer" else real_class(t))
    Counter.instances.clear()
    return drivers


IO = """
[[devices]]
name = "eye"
kind = "counter"
driver = "counter"
{options}

[[controllers]]
name = "watch"
type = "observer"
joints = []
devices = ["eye"]
"""


def config(write_config, options="", extra=IO):
    return load_config(write_config(BASE + extra.format(options=options)))


def test_a_non_joint_device_is_built_and_bound_to_the_controller_that_names_it(registry, write_config):
    rt = build(config(write_config))
    assert [d.name for d in rt.devices] == ["sim"]  # the joints are still the embedded simulator's
    assert list(rt.io) == ["eye"] and isinstance(rt.io["eye"], Counter)
    watch = rt.controllers[1]
    assert watch.device is rt.io["eye"] and not watch.mask.any()  # an observer owns no command
    assert rt.io_users == [[watch]]


@pytest.mark.parametrize("extra, key, words", [
    (IO.replace('driver = "counter"', 'driver = "counter"\njoints = ["waist"]'), "devices[0].joints", "no joints"),
    (IO.replace('devices = ["eye"]', 'devices = ["ear"]'), "controllers[1].devices", "unknown: 'ear'"),
    (IO + '[[devices]]\nname = "eye"\nkind = "counter"\ndriver = "counter"\n', "devices[1].name", "used once"),
    (IO.replace('devices = ["eye"]', 'devices = "eye"'), "controllers[1].devices", "array of distinct"),
])
def test_bad_non_joint_device_configurations_name_the_key(registry, write_config, extra, key, words):
    with pytest.raises(ConfigError) as e:
        build(load_config(write_config(BASE + extra.format(options=""))))
    assert e.value.key_path == key and words in e.value.expected


def test_a_controller_given_a_device_it_cannot_use_is_a_config_error(registry, write_config, monkeypatch):
    class Other(Hardware):
        @classmethod
        def from_config(cls, device, context):
            return cls(device.name)

    registry["sim_counter"] = Other
    with pytest.raises(ConfigError) as e:
        build(config(write_config))
    assert e.value.key_path == "controllers[1].devices" and "counter" in e.value.expected


def test_sim_replaces_the_driver_by_the_kinds_simulator_or_says_it_has_none(registry, write_config):
    cfg = config(write_config)
    assert cfg.devices[1].driver == "sim_counter"  # [sim] is in BASE
    del registry["sim_counter"]
    with pytest.raises(ConfigError) as e:
        build(cfg)
    assert e.value.key_path == "devices[1].kind" and "no simulated 'counter'" in e.value.expected


def run_daemon(cfg, tmp_path, duration):
    args = SimpleNamespace(telemetry=None, socket=str(tmp_path / "s.sock"), enforce_rt=False, duration=duration,
                           summary=None, log_level="error")
    d = Daemon(cfg, build(cfg), args)
    return d, d.run()


def test_the_daemon_brings_io_devices_up_and_down_and_ticks_them(registry, write_config, tmp_path):
    d, code = run_daemon(config(write_config), tmp_path, 0.05)
    eye = d.rt.io["eye"]
    assert code == 0
    assert eye.calls == ["configure", "activate", "deactivate", "close"]
    ticks = d.ticker.tick
    assert ticks >= 50 and eye.reads >= ticks and eye.writes >= ticks - 1
    assert d.rt.controllers[1].updates >= 50


def test_a_failing_io_device_takes_its_controller_out_and_engages_the_fallback_that_tick(
        registry, write_config, tmp_path):
    d, code = run_daemon(config(write_config, "fail_from = 21"), tmp_path, 2.0)
    eye, watch = d.rt.io["eye"], d.rt.controllers[1]
    assert code == 3  # a safe stop after a fault
    first = d.safety.faults[0]
    assert "device eye failed" in first.reason and "sensor cable unplugged" in first.reason
    # read 1 is bring-up; reads 2..21 are ticks 0..19 and read 22 (tick 20) fails: the observer ran
    # on those 20 ticks (plus once in the warm-up), never after
    assert watch.updates == 1 + 20
    assert eye.calls[-2:] == ["deactivate", "close"]
    assert np.isfinite(d.rt.state.position).all()


def test_a_device_that_cannot_confirm_its_actuators_off_is_a_hardware_error_of_the_run(
        registry, write_config, tmp_path):
    from structlog.testing import capture_logs

    with capture_logs() as logs:
        d, code = run_daemon(config(write_config, "deactivate_fails = true"), tmp_path, 0.05)
    assert code == 4 and d.stop_reason == "duration reached"  # a normal end, but not a clean one
    assert d.rt.io["eye"].calls == ["configure", "activate", "deactivate", "close"]  # deactivated once
    (error,) = [e for e in logs if e["event"] == "drives not confirmed off"]
    assert error["log_level"] == "error" and error["device"] == "eye" and "no answer to disable" in error["reason"]
    assert d.summary["exit_code"] == 4 and "no answer to disable" in d.summary["devices"]["eye"]["last_error"]
