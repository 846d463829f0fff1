"""The leg walks on the embedded simulator: the automaton's states over many gait cycles."""
import pytest

from leg_helpers import PATTERN, pattern_prefix, walk

CYCLE_S = 1.2  # the plant's gait period (hil_sim.leg_plant.LegParams.period)


@pytest.mark.slow
def test_200_gait_cycles_with_noise_give_exactly_the_tables_sequence():
    seq, _ = walk(201 * CYCLE_S)  # the walk starts in mid-swing: one cycle's time more for 200 whole ones
    assert pattern_prefix(seq) == len(seq), seq[pattern_prefix(seq) - 8: pattern_prefix(seq) + 8]
    cycles = (len(seq) - 1) // len(PATTERN)
    assert cycles >= 200, cycles
    print(f"\n201 gait periods: {len(seq)} states, {cycles} complete (1 2 3 4 1 5 1 6) cycles, no missing or extra state")


def extra_transitions(seq) -> int:
    """Transitions that are not the table's next one (after the first departure, all are)."""
    good = pattern_prefix(seq)
    return len(seq) - good


@pytest.mark.parametrize("angle_noise", [0.3, 1.0])
def test_hysteresis_off_is_measured(angle_noise):
    """The count the resolving note reports: gate toggles and transitions off the table's
    sequence, with and without hysteresis, over 30 cycles."""
    seconds = 30 * CYCLE_S
    on, toggles_on = walk(seconds, angle_noise=angle_noise)
    off, toggles_off = walk(seconds, hysteresis=False, angle_noise=angle_noise)
    print(f"\nangle noise {angle_noise}°, 30 cycles — hysteresis on: {len(on) - 1} transitions, "
          f"{extra_transitions(on)} off the sequence, {toggles_on} gate toggles; off: {len(off) - 1} transitions, "
          f"{extra_transitions(off)} off the sequence, {toggles_off} gate toggles")
    assert toggles_off > toggles_on  # without hysteresis the comparators chatter on the noise
    if angle_noise == 0.3:
        assert extra_transitions(on) == 0
