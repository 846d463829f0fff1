"""Bus-load budget, the cases a full mutation run of rtctl/busload.py found unchecked: the joints
per bus offered against what the check itself accepts, the bus count of an uneven split, the
smallest positive bitrate, and the printed kbit/s and µs columns, each from a hand computation.
What is left unchecked, and why, is in docs/mutation/busload.md."""
import pytest

from rtctl import busload
from rtctl.errors import BusLoadError

MIT_JOINT_BITS = 135 + 115  # an 8-byte command and a 6-byte reply at worst-case stuffing


@pytest.mark.parametrize("rate_hz, bitrate, fits", [
    (6.4, 10_000, 5),      # 0.8 · 10 000 / 6.4 = 1250 bits per tick = 5 × 250
    (0.8, 50_000, 200),    # 0.8 · 50 000 / 0.8 = 50 000 bits = 200 × 250
    (3.2, 20_000, 20),     # 0.8 · 20 000 / 3.2 = 5000 bits = 20 × 250
])
def test_the_joints_per_bus_offered_are_the_most_the_check_accepts(rate_hz, bitrate, fits):
    """A budget that holds a whole number of joints exactly offers all of them, not one fewer
    (catches the budget per tick floored before the per-bus frames are taken off)."""
    full = busload.bus_load("a", "mit", fits, rate_hz, bitrate)
    assert busload.check_bus_load(full, "r.toml", "buses.a") is full
    over = busload.bus_load("a", "mit", fits + 1, rate_hz, bitrate)
    assert over.max_joints() == fits
    with pytest.raises(BusLoadError) as err:
        busload.check_bus_load(over, "r.toml", "buses.a")
    assert f"over 2 buses (≤ {fits} per bus" in str(err.value)


def test_an_uneven_split_rounds_the_bus_count_up():
    """7 MIT joints at 1 kHz on 1 Mbit/s: 800 bits of budget per tick hold 3 joints (750 bits),
    so 7 joints need ⌈7/3⌉ = 3 buses (catches a floored joints / per-bus quotient)."""
    load = busload.bus_load("arm", "mit", 7, 1000, 1_000_000)
    with pytest.raises(BusLoadError) as err:
        busload.check_bus_load(load, "r.toml", "buses.arm")
    assert "split the joints over 3 buses (≤ 3 per bus at 1000 Hz)" in str(err.value)


def test_one_bit_per_second_is_a_positive_bitrate():
    """The refusal is for bitrates that are not positive; 1 bit/s is (catches `bitrate <= 1`)."""
    load = busload.bus_load("a", "mit", 1, 1, 1)
    assert load.bitrate == 1 and load.load == MIT_JOINT_BITS  # 250 bits a second on 1 bit/s


def test_the_message_gives_the_bits_per_second_in_kbit_not_floored():
    """3 MIT joints at 333 Hz: 750 bits × 333 = 249 750 bit/s = 249.75 kbit/s (catches `//`)."""
    load = busload.bus_load("arm", "mit", 3, 333, 1_000_000)
    assert "750 bits/tick = 249.75 kbit/s on 1000 kbit/s" in load.describe()


def test_the_table_gives_a_tick_of_one_second_as_a_million_microseconds():
    """40 MIT joints are 40 × 250 = 10 000 bits per tick: exactly 1 s at 10 kbit/s, printed as
    1000000 µs (catches the µs scale 1e6 off by one either way, visible once a tick takes ≥ 1 s)."""
    row = busload.format_budget([busload.bus_load("slow", "mit", 40, 1, 10_000)]).splitlines()[1]
    assert row.split()[:7] == ["slow", "mit", "40", "1", "10", "1000000", "100%"]
