"""Fuzzing the shipped run configurations: one key or array element of one config mutated at a
time (NaN, ±inf, negative, zero, huge, wrong type, wrong length, deleted, extra key).
`rtctl check` — which runs exactly what `run` does before it touches a device
(rtctl.daemon.prepare) — must exit 0 or 2, never raise (a traceback) or hang; a 2 names the
file, and a non-finite number or a string where a number was is refused naming its key."""
from __future__ import annotations

import shutil
import tomllib

import pytest
import tomli_w
from hypothesis import given, strategies as st

from fuzz_helpers import (FUZZ, MUTATIONS, NON_FINITE, acceptable_names, get, is_number, key_name, leaves, mutate,
                          rtctl_in_process)
from runtime_helpers import ROOT

CONFIGS = sorted((ROOT / "configs").glob("*.toml"))


def _passed_to_python_can(path) -> bool:
    """A [devices.bus] keyword rtctl does not read itself (python-can's own, e.g. slcan's
    sleep_after_open): its type is python-can's to check when the bus opens."""
    return "bus" in path[:-1] and path[-1] not in ("interface", "channel", "host", "port", "bitrate", "timeout")


@pytest.fixture(autouse=True)
def _hil_environment(monkeypatch):
    monkeypatch.setenv("HIL_SIM_TTY", "/dev/null")  # what hil-sim would print; check opens nothing


@pytest.mark.parametrize("config", CONFIGS, ids=lambda p: p.stem)
def test_fuzz_config_mutations_exit_0_or_2_naming_the_key(config, tmp_path):
    doc = tomllib.loads(config.read_text())
    paths = list(leaves(doc))
    assert rtctl_in_process("check", config)[0] == 0  # the unmutated config is valid
    # the mutants live in a copy of configs/, so that their relative paths (robots, tables) resolve
    shutil.copytree(config.parent, tmp_path / "configs")

    @FUZZ
    @given(path=st.sampled_from(paths), how=st.sampled_from(MUTATIONS))
    def case(path, how):
        target = tmp_path / "configs" / f"fuzz_{config.name}"
        target.write_text(tomli_w.dumps(mutate(doc, path, how)))
        code, _, err = rtctl_in_process("check", target)
        assert code in (0, 2), (key_name(path), how, code, err)
        if code == 2:
            assert "Traceback" not in err and str(target) in err, (key_name(path), how, err)
        if how in NON_FINITE and is_number(get(doc, path)):
            assert code == 2 and key_name(path) in err, (key_name(path), how, err)
        if how == "string" and is_number(get(doc, path)) and not _passed_to_python_can(path):
            assert code == 2 and any(k in err for k in acceptable_names(path)), (key_name(path), how, err)

    case()


@pytest.mark.parametrize("value, code", [("fuzz", 2), (True, 2), (-0.001, 2), (float("inf"), 2), (0, 0), (0.002, 0)])
def test_the_bus_timeout_the_driver_reads_is_a_number_of_seconds(tmp_path, value, code):
    """slcan's serial read ``timeout`` also times the driver's reads: one that is no number of
    seconds exits 2 naming it, before anything opens (a string was a traceback)."""
    config = ROOT / "configs" / "three_joint_slcan.toml"
    doc = tomllib.loads(config.read_text())
    doc["devices"][0]["bus"]["timeout"] = value
    shutil.copytree(config.parent, tmp_path / "configs")
    target = tmp_path / "configs" / config.name
    target.write_text(tomli_w.dumps(doc))
    got, _, err = rtctl_in_process("check", target)
    assert got == code, err
    if code == 2:
        assert "Traceback" not in err and "devices[0].bus.timeout" in err and ("seconds" in err or "finite" in err), err
