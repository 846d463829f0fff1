"""The leg board codec: golden frames (CRC from an independent implementation), every 1- and
2-bit error detected and the next frame found, random bytes never crash it."""
import itertools

import numpy as np
import pytest
from crccheck.crc import Crc16CcittFalse
from hypothesis import given, settings, strategies as st

from drivers.protocols import leg_board as lb


def _reference_frame(kind: int, body: bytes) -> bytes:
    data = bytes([kind]) + body
    return b"\xa5\x5a" + data + Crc16CcittFalse.calc(data).to_bytes(2, "little")


def test_golden_command_frame():
    frame = lb.encode_command(7, lb.INCREASE, lb.DECREASE)
    assert bytes(frame) == _reference_frame(0x43, bytes([7, 0b1001]))
    assert bytes(frame).hex() == "a55a430709df80"  # sync, 'C', seq 7, knee 10 ankle 01, CRC
    d = lb.Decoder(lb.COMMAND)
    assert d.feed(frame) == 1 and lb.unpack_actions(d.actions) == (lb.INCREASE, lb.DECREASE) and d.seq == 7
    # 00 hold, 11 release: knee in bits 3-2, ankle in bits 1-0
    assert bytes(lb.encode_command(8, lb.RELEASE, lb.HOLD)) == _reference_frame(0x43, bytes([8, 0b1100]))
    assert bytes(lb.encode_command(9, lb.HOLD, lb.RELEASE)) == _reference_frame(0x43, bytes([9, 0b0011]))


def test_golden_sensor_frame():
    channels = [0.5236, -0.001, 0.35, 1.2, 0.0]  # rad, rad, rad, body weights
    frame = lb.encode_sensor(255, lb.WATCHDOG | 0b1111, channels)
    body = bytes([255, 0x1F]) + b"".join(int(round(c * 1000)).to_bytes(2, "little", signed=True) for c in channels)
    assert bytes(frame) == _reference_frame(0x53, body) and len(frame) == lb.SENSOR_LENGTH == 17
    d = lb.Decoder(lb.SENSOR)
    assert d.feed(frame) == 1 and d.seq == 255 and d.status == 0x1F
    assert np.allclose(d.channels, channels, atol=5e-4)



def test_sensor_status_bits_and_saturated_channels():
    # status: the applied actions in bits 0-3, the watchdog in bit 4; channels clip to ±32767 counts
    status = lb.WATCHDOG | lb.pack_actions(lb.INCREASE, lb.HOLD)
    frame = lb.encode_sensor(1, status, [40.0, -40.0, 32.767, -32.767, 32.7674])
    body = bytes([1, 0b1_1000]) + b"".join(v.to_bytes(2, "little", signed=True) for v in (32767, -32767, 32767, -32767, 32767))
    assert bytes(frame) == _reference_frame(0x53, body)


def _flips(frame: bytes, bits):
    out = bytearray(frame)
    for b in bits:
        out[b // 8] ^= 1 << (b % 8)
    return bytes(out)


@pytest.mark.parametrize("kind", [lb.SENSOR, lb.COMMAND])
def test_every_one_and_two_bit_error_is_detected_and_the_next_frame_found(kind):
    if kind == lb.SENSOR:
        frames = [lb.encode_sensor(s, 3, [0.1 * s, -0.2, 0.3, 0.9, 0.05]) for s in (1, 2)]
    else:
        frames = [lb.encode_command(s, s & 3, 3 - (s & 3)) for s in (1, 2)]
    bad, good = bytes(frames[0]), bytes(frames[1])
    nbits = 8 * len(bad)
    cases = 0
    for k in (1, 2):
        for bits in itertools.combinations(range(nbits), k):
            d = lb.Decoder(kind)
            assert d.feed(_flips(bad, bits)) == 0, bits  # detected: no frame accepted
            assert d.feed(good) == 1 and d.seq == 2, bits  # and the next intact frame is found
            cases += 1
    assert cases == nbits + nbits * (nbits - 1) // 2


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=300), st.integers(0, 255))
def test_random_bytes_never_crash_and_the_next_frame_is_found(garbage, seq):
    d = lb.Decoder(lb.SENSOR)
    d.feed(garbage)
    assert len(d._buf) < d.length  # what it keeps is bounded: at most one frame's beginning
    good = lb.encode_sensor(seq, 0, [0.0, 0.1, 0.2, 0.3, 0.4])
    d.feed(good)
    assert d.seq == seq and np.allclose(d.channels, [0.0, 0.1, 0.2, 0.3, 0.4])


def test_split_frames_lost_frames_and_foreign_frames_are_counted():
    d = lb.Decoder(lb.SENSOR)
    stream = b"".join(lb.encode_sensor(s, 0, [0, 0, 0, 0, 0]) for s in (10, 11, 14))
    stream += lb.encode_command(3, 0, 0)  # our own command echoed (loop://): not a sensor frame
    stream += lb.encode_sensor(15, 0, [0, 0, 0, 0, 0])
    for i in range(0, len(stream), 5):  # byte by byte chunks
        d.feed(stream[i:i + 5])
    assert d.counters["frames"] == 4 and d.counters["lost_frames"] == 2 and d.seq == 15
    assert d.counters["crc_errors"] == 0 and d.counters["skipped_bytes"] == lb.COMMAND_LENGTH


def test_lost_frames_are_counted_from_seq_0_and_across_the_wrap():
    d = lb.Decoder(lb.SENSOR)
    for seq in (0, 3, 100, 200, 254, 255, 0, 1, 120):  # steps 3, 97, 100, 54, 1, 1, 1, 119
        d.feed(lb.encode_sensor(seq, 0, [0.0] * 5))
    assert d.counters["frames"] == 9 and d.counters["lost_frames"] == 2 + 96 + 99 + 53 + 118
    assert d.counters["repeated_frames"] == d.counters["out_of_order"] == 0


def test_a_repeated_frame_or_a_backwards_seq_is_refused_not_counted_as_hundreds_lost():
    """Defect 3 of issue 25: a proxy resent one sensor frame 1311 times; each repeat counted as
    255 lost frames (334,305 in all) and as a new frame. A repeat (step 0) and a step back
    (128…255, serial-number arithmetic) are refused: no new frame, their values not taken."""
    d = lb.Decoder(lb.SENSOR)
    assert d.feed(lb.encode_sensor(17, 0, [0.1] * 5)) == 1
    replay = lb.encode_sensor(17, 0, [0.2] * 5)
    assert sum(d.feed(replay) for _ in range(1311)) == 0
    for back in (16, 17 - 100, 17 - 128):  # backwards by 1, 100, 128
        assert d.feed(lb.encode_sensor(back & 0xFF, 0, [0.3] * 5)) == 0
    assert (d.seq, d.counters["frames"], d.counters["lost_frames"]) == (17, 1, 0)
    assert (d.counters["repeated_frames"], d.counters["out_of_order"]) == (1311, 3)
    assert np.all(d.channels == 0.1)  # the values of the frame taken, not of the refused ones
    assert d.feed(lb.encode_sensor(17 + 127, 0, [0.4] * 5)) == 1 and d.counters["lost_frames"] == 126  # forward


def test_encoders_check_their_inputs():
    with pytest.raises(ValueError):
        lb.encode_command(0, 4, 0)
    with pytest.raises(ValueError):
        lb.encode_sensor(0, 0, [0.0] * 4)
    with pytest.raises(ValueError):
        lb.encode_sensor(0, 0, [np.nan] * 5)


def test_every_action_code_round_trips_and_no_other_is_accepted():
    codes = [(knee, ankle) for knee in range(4) for ankle in range(4)]
    assert [lb.unpack_actions(lb.pack_actions(*code)) for code in codes] == codes
    assert sorted(lb.pack_actions(*code) for code in codes) == list(range(16))  # 4 bits, all used
    for knee, ankle in ((-1, 0), (4, 0), (0, -1), (0, 4)):
        with pytest.raises(ValueError):
            lb.pack_actions(knee, ankle)


def test_every_status_byte_splits_into_the_applied_actions_and_the_fault_bits():
    """The documented status byte: bits 0-3 echo the actions applied (any of the 16 codes is a
    board under command), bit 4 is the watchdog's lock and bits 5-7 are undefined: any of those
    four means the board is not under our command."""
    for status in range(256):
        actions, faults = status & 0b0000_1111, status & 0b1111_0000
        assert status & lb.ACTIONS_MASK == actions, status
        assert status & lb.STATUS_FAULTS == faults, status
    assert lb.WATCHDOG == 0b1_0000


def test_a_fresh_decoder_reports_nothing_received():
    # before the first frame: no sequence number, no watchdog trip, no actions (hold), no load
    for kind in (lb.SENSOR, lb.COMMAND):
        d = lb.Decoder(kind)
        assert (d.seq, d.status, d.actions) == (-1, 0, lb.HOLD) and not d.channels.any()
        assert d.counters == {"frames": 0, "crc_errors": 0, "skipped_bytes": 0, "lost_frames": 0,
                              "repeated_frames": 0, "out_of_order": 0}


def test_a_corrupted_frame_is_one_crc_error_and_all_its_bytes_are_skipped():
    bad = lb.encode_sensor(1, 0, [0.1, 0.2, 0.3, 0.4, 0.5])
    bad[-1] ^= 0x40  # CRC
    d = lb.Decoder(lb.SENSOR)
    assert d.feed(bad + lb.encode_sensor(2, 0, [0.0] * 5)) == 1 and d.seq == 2
    assert d.counters == {"frames": 1, "crc_errors": 1, "skipped_bytes": lb.SENSOR_LENGTH, "lost_frames": 0,
                          "repeated_frames": 0, "out_of_order": 0}


def test_skipped_bytes_count_exactly_the_bytes_outside_frames():
    # garbage ending in A5, which may begin a sync and is kept for the next feed
    d = lb.Decoder(lb.SENSOR)
    assert d.feed(b"\x00\x11\xa5") == 0 and d.counters["skipped_bytes"] == 2
    ends_in_a5 = lb.encode_sensor(5, 0, [0.0] * 5)  # CRC 0xA56C, sent low byte first
    assert ends_in_a5[-1] == 0xA5
    assert d.feed(ends_in_a5) == 1 and d.counters["skipped_bytes"] == 3  # the lone A5
    # a frame's own last A5 is no garbage: nothing more is skipped
    assert d.feed(lb.encode_sensor(6, 0, [0.0] * 5)) == 1 and d.counters["skipped_bytes"] == 3
    # garbage after a frame in the same read; a sync split across two reads
    assert d.feed(lb.encode_sensor(7, 0, [0.0] * 5) + b"\x01\x02\xa5") == 1 and d.counters["skipped_bytes"] == 5
    assert d.feed(lb.encode_sensor(8, 0, [0.0] * 5)[1:]) == 1 and d.seq == 8 and d.counters["skipped_bytes"] == 5


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=60), st.lists(st.integers(1, 40), max_size=8))
def test_skipped_bytes_are_the_garbage_however_the_stream_is_cut(garbage, cuts):
    frames = [lb.encode_sensor(s, 0, [0.0, 0.1, 0.2, 0.3, 0.4]) for s in (4, 5)]
    stream = garbage + frames[0] + frames[1]
    d, at = lb.Decoder(lb.SENSOR), 0
    for n in [*cuts, len(stream)]:
        d.feed(stream[at:at + n])
        at += n
    assert d.counters["frames"] == 2 and d.seq == 5 and d.counters["skipped_bytes"] == len(garbage)
