"""The CAN configuration through the CLI: the bus-load budget `rtctl check` prints and enforces,
option errors, and the embedded simulator through the CAN codec ([sim] transport = "can")."""
import json

import numpy as np

from hil_helpers import CONFIGS, read, rtctl
from runtime_helpers import BASE

PUMA = CONFIGS / "robots" / "puma560.toml"
JOINTS = ["waist", "shoulder", "elbow", "wrist_roll", "wrist_bend", "flange"]


def can_config(rate_hz, *buses, extra=""):
    """A run config whose joints sit on MIT drives on the given buses: (channel, joints) pairs."""
    text = f'[robot]\ndescription = "{PUMA}"\n[loop]\nrate_hz = {rate_hz}\n'
    for k, (channel, joints) in enumerate(buses):
        names = JOINTS[joints[0]:joints[1]]
        text += (f'[[devices]]\nname = "d{k}"\ndriver = "mit_can"\njoints = {json.dumps(names)}\n{extra}'
                 f'[devices.bus]\ninterface = "socketcan"\nchannel = "{channel}"\nbitrate = 1000000\n')
    return text


def check(write_config, text):
    return rtctl("check", write_config(text), timeout=60)


def test_check_refuses_six_mit_joints_at_1khz_on_one_bus(write_config):
    result = check(write_config, can_config(1000, ("can0", (0, 6))))
    assert result.returncode == 2
    err = result.stderr
    assert "devices[0].bus" in err and "150 %" in err and "Traceback" not in err
    # the ways out, with their numbers: 0.8 · 1e6 / 1500 bits = 533 Hz; 3 joints per bus at 1 kHz
    assert "533 Hz" in err and "2 buses" in err and "CAN FD" in err


def test_check_accepts_six_joints_at_500hz_or_on_two_buses(write_config):
    slow = check(write_config, can_config(500, ("can0", (0, 6))))
    assert slow.returncode == 0, slow.stderr
    (row,) = [line for line in slow.stdout.splitlines() if line.startswith("can0")]
    assert row.split()[1:4] == ["mit", "6", "500"] and row.endswith("75%")
    split = check(write_config, can_config(1000, ("can0", (0, 3)), ("can1", (3, 6))))
    assert split.returncode == 0, split.stderr
    rows = [line for line in split.stdout.splitlines() if line.startswith("can")]
    assert [r.split()[0] for r in rows] == ["can0", "can1"] and all(r.endswith("75%") for r in rows)


def test_two_devices_on_the_same_bus_count_together(write_config):
    result = check(write_config, can_config(1000, ("can0", (0, 3)), ("can0", (3, 6))))
    assert result.returncode == 2 and "devices[1].bus" in result.stderr and "150 %" in result.stderr


def test_option_errors_name_the_key(write_config):
    unset = can_config(500, ("can0", (0, 6))).replace('channel = "can0"', 'channel = "${RTCTL_TEST_UNSET_VAR}"')
    checked = check(write_config, unset)  # check lists it; run needs it
    assert checked.returncode == 0 and "RTCTL_TEST_UNSET_VAR" in checked.stdout
    result = rtctl("run", write_config(unset))
    assert result.returncode == 2 and "devices[0].bus.channel" in result.stderr and "RTCTL_TEST_UNSET_VAR" in result.stderr
    clash = check(write_config, can_config(500, ("can0", (0, 6)), extra="ids = [1, 2, 3, 3, 5, 6]\n"))
    assert clash.returncode == 2 and "devices[0].ids" in clash.stderr
    wide = check(write_config, can_config(500, ("can0", (0, 6)), extra='drive_model = "dm4310"\nprotocol = "mit"\n'))
    assert wide.returncode == 2 and "mit8" in wide.stderr


CAN_SIM = BASE.replace("substeps = 4", 'substeps = 4\ntransport = "can"')


def test_embedded_can_simulator_is_bit_for_bit_reproducible(write_config, tmp_path):
    config = write_config(CAN_SIM)
    runs = []
    for k in range(2):
        telemetry, summary = tmp_path / f"run{k}.msgpack", tmp_path / f"summary{k}.json"
        result = rtctl("run", config, "--duration", "1.0", "--telemetry", telemetry, "--summary", summary,
                       "--socket", tmp_path / f"s{k}")
        assert result.returncode == 0, result.stderr[-3000:]
        runs.append((read(telemetry), json.loads(summary.read_text())))
    (a, sa), (b, _) = runs
    assert a.rows == b.rows > 1000
    for column in ("t", "q", "qd", "q_des", "tau"):
        assert np.array_equal(a[column], b[column]), column
    # it went through the driver and the codec: one command/reply cycle per tick, none missing
    counters = sa["devices"]["sim"]["counters"]
    assert counters["cycles"] == sa["timing"]["ticks"] and counters["missing_replies"] == 0
    # tracking through the codec (one period of measurement delay, quantisation): measured
    # max 4.6 mrad on the shipped trajectory, vs 0.12 mrad for the direct simulator
    assert sa["tracking_error_rad"]["max_all"] < 0.02


def cia402_config(rate_hz, joints=6, extra=""):
    """A run config whose first ``joints`` joints sit on CiA 402 drives on one bus (the rest on MIT)."""
    text = (f'[robot]\ndescription = "{PUMA}"\n[loop]\nrate_hz = {rate_hz}\n[[devices]]\nname = "arm"\n'
            f'driver = "cia402"\njoints = {json.dumps(JOINTS[:joints])}\nrated_torque = 30.0\n{extra}'
            f'[devices.bus]\ninterface = "socketcan"\nchannel = "can0"\nbitrate = 1000000\n')
    if joints < 6:
        text += (f'[[devices]]\nname = "wrist"\ndriver = "mit_can"\njoints = {json.dumps(JOINTS[joints:])}\n'
                 f'[devices.bus]\ninterface = "socketcan"\nchannel = "can1"\nbitrate = 1000000\n')
    return text


def test_check_computes_the_cia402_pdo_load(write_config):
    # per drive 95 + 135 + 95 bits (RPDO1 4 B, TPDO1 8 B, TPDO2 4 B), one SYNC of 55 bits
    six = check(write_config, cia402_config(500))
    assert six.returncode == 2 and "100 %" in six.stderr and "2005 bits/tick" in six.stderr
    # 0.8 · 1e6 / 2005 = 399 Hz; (0.8 · 1e6 / 500 − 55) / 325 = 4.75 drives per bus
    assert "≤ 399 Hz" in six.stderr and "2 buses (≤ 4 per bus at 500 Hz)" in six.stderr
    three = check(write_config, cia402_config(500, joints=3))
    assert three.returncode == 0, three.stderr
    rows = [line.split() for line in three.stdout.splitlines() if line.startswith("can")]
    assert rows == [["can0", "cia402", "3", "500", "1000", "1030", "52%"], ["can1", "mit", "3", "500", "1000", "750", "38%"]]


def test_cia402_option_errors_name_the_key(write_config):
    cases = {
        "devices[0].ids": cia402_config(500, 3, extra="ids = [1, 1, 2]\n"),
        "devices[0].eds": cia402_config(500, 3, extra='eds = "no/such.eds"\n'),
        "devices[0].heartbeat_timeout": cia402_config(500, 3, extra="heartbeat_period = 0.1\nheartbeat_timeout = 0.05\n"),
        "devices[0].drives.elbow.rated_torque": cia402_config(500, 3, extra="[devices.drives.elbow]\nrated_torque = -1.0\n"),
    }
    for key, text in cases.items():
        result = check(write_config, text)
        assert result.returncode == 2 and key in result.stderr and "Traceback" not in result.stderr, (key, result.stderr)
