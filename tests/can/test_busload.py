"""Bus-load budget: the stuffed-frame formula against a bit-stuffing simulation and published
numbers, and the refusal with its ways out."""
import pytest
from hypothesis import given, settings, strategies as st

from rtctl import busload
from rtctl.errors import BusLoadError, ConfigError


def stuff_bits(bits):
    """Stuff bits CAN inserts into ``bits``: one after every run of 5 equal bits (the stuff bit
    itself starts the next run)."""
    count, run, last = 0, 0, None
    for b in bits:
        run = run + 1 if b == last else 1
        last = b
        if run == 5:
            count += 1
            last, run = 1 - b, 1
    return count


def worst_case_pattern(k):
    # 5 equal bits, then groups of 4 that each complete a run with the previous stuff bit
    bits, b = [0] * 5, 0
    while len(bits) < k:
        b = 1 - b  # the stuff bit after a run of (1-b)'s is b: 4 more b's end the next run
        bits += [b] * 4
    return bits[:k]


@pytest.mark.parametrize("n", range(9))
def test_frame_bits_is_the_worst_stuffing(n):
    k = 34 + 8 * n  # the stuffable part of a standard frame
    assert busload.frame_bits(n) == 8 * n + 47 + stuff_bits(worst_case_pattern(k))


@settings(max_examples=300, deadline=None)
@given(n=st.integers(0, 8), data=st.data())
def test_no_bit_pattern_stuffs_more(n, data):
    k = 34 + 8 * n
    bits = data.draw(st.lists(st.integers(0, 1), min_size=k, max_size=k))
    assert 8 * n + 47 + stuff_bits(bits) <= busload.frame_bits(n)


def test_published_frame_lengths():
    # Davis et al. 2007 (CAN schedulability revised): 135 bits for 8 bytes; spec: 115 for 6
    assert busload.frame_bits(8) == 135
    assert busload.frame_bits(6) == 115
    with pytest.raises(ValueError):
        busload.frame_bits(9)


def test_spec_numbers():
    six = busload.bus_load("arm", "mit", 6, 1000, 1_000_000)
    assert six.bits_per_tick == 6 * 250 and six.load == pytest.approx(1.5)
    assert busload.bus_load("arm", "mit", 6, 500, 1_000_000).load == pytest.approx(0.75)
    three = busload.bus_load("arm", "mit", 3, 1000, 1_000_000)
    assert three.load == pytest.approx(0.75) and three.time_per_tick_s == pytest.approx(750e-6)
    # CiA 402: per joint RPDO 4 B (95 bits) + TPDO1 8 B (135) + TPDO2 4 B (95), one SYNC (55) per bus
    assert busload.bus_load("x", "cia402", 2, 1000, 1_000_000).bits_per_tick == 2 * (95 + 135 + 95) + 55


def test_six_joints_at_1khz_on_one_bus_refused_with_ways_out():
    load = busload.bus_load("arm", "mit", 6, 1000, 1_000_000)
    with pytest.raises(BusLoadError) as err:
        busload.check_bus_load(load, "robot.toml", "buses.arm")
    e = err.value
    assert isinstance(e, ConfigError) and e.file == "robot.toml" and e.key_path == "buses.arm"
    msg = str(e)
    assert "150 %" in msg and "80 %" in msg
    assert "≤ 533 Hz" in msg  # 0.8 · 1e6 / 1500
    assert "2 buses (≤ 3 per bus" in msg
    assert "CAN FD" in msg


def test_accepted_at_500hz_or_on_two_buses_or_with_three_joints():
    busload.check_bus_load(busload.bus_load("arm", "mit", 6, 500, 1_000_000), "r.toml", "buses.arm")
    for name in ("a", "b"):
        busload.check_bus_load(busload.bus_load(name, "mit", 3, 1000, 1_000_000), "r.toml", f"buses.{name}")
    # a stricter limit refuses the same 75 %
    with pytest.raises(BusLoadError):
        busload.check_bus_load(busload.bus_load("a", "mit", 3, 1000, 1_000_000), "r.toml", "buses.a", limit=0.7)


def test_budget_table():
    table = busload.format_budget(
        [busload.bus_load("a", "mit", 3, 1000, 1_000_000), busload.bus_load("b", "mit", 6, 1000, 1_000_000)]
    )
    lines = table.splitlines()
    assert len(lines) == 3 and "75%" in lines[1] and "150%" in lines[2] and "limit" in lines[2]


@pytest.mark.parametrize("protocol, joints", [("mit", 3), ("mit", 6), ("cia402", 4)])
def test_exactly_the_limit_is_accepted_and_one_bit_per_second_less_capacity_is_not(protocol, joints):
    bits = busload.bus_load("a", protocol, joints, 1000, 1_000_000).bits_per_tick
    exact = bits * 1000 * 5 // 4  # the bitrate at which the load is exactly 80 %
    at_limit = busload.bus_load("a", protocol, joints, 1000, exact)
    assert at_limit.load == busload.DEFAULT_LIMIT == 0.8
    assert busload.check_bus_load(at_limit, "r.toml", "buses.a") is at_limit
    assert "limit" not in busload.format_budget([at_limit]).splitlines()[1]
    over = busload.bus_load("a", protocol, joints, 1000, exact - 1)
    with pytest.raises(BusLoadError):
        busload.check_bus_load(over, "r.toml", "buses.a")
    assert "limit" in busload.format_budget([over]).splitlines()[1]


def test_frame_lengths_and_the_data_byte_range():
    # worst-case stuffed lengths (Davis et al. 2007): 0, 4, 6, 8 data bytes
    assert [busload.frame_bits(n) for n in (0, 4, 6, 8)] == [55, 95, 115, 135]
    for bad in (-1, 9):
        with pytest.raises(ValueError):
            busload.frame_bits(bad)
    assert busload.bus_load("a", "mit8", 3, 1000, 1_000_000).bits_per_tick == 3 * (135 + 135)


def test_the_ways_out_are_computed_not_rounded_early():
    load = busload.bus_load("arm", "mit", 6, 1000, 1_000_000)
    assert load.max_rate_hz() == pytest.approx(0.8e6 / 1500, rel=1e-12)  # 533.33 Hz, not 533
    assert "1500 bits/tick = 1500 kbit/s on 1000 kbit/s: 150 %" in load.describe()
    # CiA 402: 325 bits per drive and one 55-bit SYNC per bus; at 500 Hz (1600 bits of budget per
    # tick) (1600 − 55) / 325 = 4.75 → 4 drives per bus
    assert busload.bus_load("b", "cia402", 6, 500, 1_000_000).max_joints() == 4


def test_when_not_even_one_joint_fits_no_split_is_offered():
    load = busload.bus_load("slow", "mit", 2, 1000, 125_000)  # 500 bits/tick on 100 bits of budget
    assert load.max_joints() == 0
    with pytest.raises(BusLoadError) as err:
        busload.check_bus_load(load, "r.toml", "buses.slow")
    assert "split" not in str(err.value) and "≤ 200 Hz" in str(err.value)


def test_a_split_is_offered_down_to_one_joint_per_bus():
    # 250 bits per MIT joint; 1 Mbit at 3 kHz leaves 266 bits of budget per tick: one joint per bus
    load = busload.bus_load("a", "mit", 2, 3000, 1_000_000)
    with pytest.raises(BusLoadError) as err:
        busload.check_bus_load(load, "r.toml", "buses.a")
    assert "split the joints over 2 buses (≤ 1 per bus at 3000 Hz)" in str(err.value)


@pytest.mark.parametrize("kw", [{"rate_hz": 0}, {"bitrate": 0}, {"joints": -1}])
def test_impossible_buses_are_refused(kw):
    args = {"joints": 3, "rate_hz": 1000, "bitrate": 1_000_000, **kw}
    with pytest.raises(ValueError):
        busload.bus_load("a", "mit", args["joints"], args["rate_hz"], args["bitrate"])


def test_slow_rates_are_buses_like_any_other():
    assert busload.bus_load("a", "mit", 3, 0.5, 1_000_000).bits_per_second == 375.0


def test_a_bus_whose_own_frames_overflow_it_carries_no_joint_not_fewer():
    # a 55-bit SYNC every 0.5 ms on 125 kbit/s is 88 % before any drive
    assert busload.bus_load("b", "cia402", 1, 2000, 125_000).max_joints() == 0


def test_odd_bitrates_are_shown_as_they_are():
    load = busload.bus_load("b", "mit", 1, 100, 83_333)
    assert "on 83.333 kbit/s" in load.describe()
    assert busload.format_budget([load]).splitlines()[1].split()[4] == "83.333"


def test_the_frame_tables_are_shared_and_cannot_be_changed_in_place():
    import dataclasses

    with pytest.raises(dataclasses.FrozenInstanceError):
        busload.PROTOCOLS["mit"].per_joint = (8,)
    with pytest.raises(dataclasses.FrozenInstanceError):
        busload.bus_load("a", "mit", 1, 1000, 1_000_000).joints = 2


def test_a_bus_without_joints_costs_only_its_own_frames():
    assert busload.bus_load("a", "mit", 0, 1000, 1_000_000).bits_per_tick == 0
    assert busload.bus_load("a", "cia402", 0, 1000, 1_000_000).bits_per_tick == 55  # the SYNC


def test_budget_table_units():
    (header, row) = busload.format_budget([busload.bus_load("b", "mit", 6, 1000, 1_000_000)]).splitlines()
    assert header.split() == ["bus", "protocol", "joints", "rate", "Hz", "kbit/s", "µs/tick", "load"]
    assert row.split()[:7] == ["b", "mit", "6", "1000", "1000", "1500", "150%"]
    assert row.endswith("> 80 % limit")


def test_a_cia402_devices_budget_is_its_pdos_per_joint_and_one_empty_sync():
    """The driver's own budget from the shipped EDS (RPDO1 4 B; TPDO1 8 B, TPDO2 4 B per joint) and
    one SYNC with no data per bus, each frame at its worst-case stuffed length 8n + 47 + ⌊(34 + 8n − 1)/4⌋
    bits (ISO 11898-1, standard identifier) — 1030 bits at 1 Mbit/s for 3 joints (issue 27 part 3:
    a cia402_driver sample survivor gave the SYNC a data byte)."""
    from pathlib import Path

    from rtctl.config import load_config
    from rtctl.runtime import build

    def bits(n):
        return 8 * n + 47 + (34 + 8 * n - 1) // 4

    config = Path(__file__).resolve().parents[2] / "configs" / "puma560_hil_cia402.toml"
    lines = build(load_config(config)).bus_budget()
    row = next(line.split() for line in lines if line.startswith("can0"))
    assert row[1] == "cia402" and row[2] == "3"
    assert int(row[5]) == 3 * (bits(4) + bits(8) + bits(4)) + bits(0) == 1030  # µs per tick at 1 Mbit/s
