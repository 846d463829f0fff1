"""Packing pixels into words (the documented bit order) and the digitiser.

The reference for the bit order is written out here independently: a row is a string of
bits, each pixel MSB first, pixels in order; every word_bits of it form a word (big-endian
reading), stored little-endian in memory.
"""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from rtctl.vision.pixels import digitise, pack, unpack

LEVELS = {2: 1, 4: 2, 16: 4, 256: 8}


def reference_words(pixels: np.ndarray, bits: int, word_bits: int) -> np.ndarray:
    rows = []
    for row in pixels:
        stream = "".join(format(int(p), f"0{bits}b") for p in row)
        rows.append([int(stream[k:k + word_bits], 2) for k in range(0, len(stream), word_bits)])
    return np.array(rows, dtype=f"<u{word_bits // 8}")


@settings(max_examples=40, deadline=None)
@given(levels=st.sampled_from(sorted(LEVELS)), word_bits=st.sampled_from([8, 16, 32]),
       rows=st.integers(1, 5), words=st.integers(1, 6), data=st.data())
def test_round_trip_and_bit_order(levels, word_bits, rows, words, data):
    bits = LEVELS[levels]
    width = words * word_bits // bits
    values = data.draw(st.lists(st.integers(0, levels - 1), min_size=rows * width, max_size=rows * width))
    pixels = np.array(values, dtype=np.uint8).reshape(rows, width)
    packed = pack(pixels, bits, word_bits)
    np.testing.assert_array_equal(packed, reference_words(pixels, bits, word_bits))
    out = np.full_like(pixels, 0xAA)
    np.testing.assert_array_equal(unpack(packed, bits, out), pixels)


@pytest.mark.parametrize("pixels, bits, word_bits, word, memory", [
    ([1, 2, 3, 4, 5, 6, 7, 8], 4, 32, 0x12345678, [0x78, 0x56, 0x34, 0x12]),
    ([0x11, 0x22, 0x33, 0x44], 8, 32, 0x11223344, [0x44, 0x33, 0x22, 0x11]),
    ([0xAB, 0xCD], 8, 16, 0xABCD, [0xCD, 0xAB]),
    ([3, 0, 1, 2], 2, 8, 0xC6, [0xC6]),
    ([1] + [0] * 14 + [1], 1, 16, 0x8001, [0x01, 0x80]),
    ([1, 0, 1, 1, 0, 0, 0, 1], 1, 8, 0xB1, [0xB1]),
    ([0xF, 0x0, 0xA, 0x5], 4, 16, 0xF0A5, [0xA5, 0xF0]),
])
def test_golden_words(pixels, bits, word_bits, word, memory):
    packed = pack(np.array([pixels], dtype=np.uint8), bits, word_bits)
    assert packed.shape == (1, 1) and int(packed[0, 0]) == word
    assert packed.view(np.uint8).tolist() == [memory]


def test_pack_keeps_neighbours_when_a_pixel_is_too_large():
    assert int(pack(np.array([[0xFF, 0, 0, 0]], dtype=np.uint8), 2, 8)[0, 0]) == 0xC0


@pytest.mark.parametrize("call", [
    lambda: unpack(np.zeros((2, 4), np.uint32), 3, np.zeros((2, 32), np.uint8)),  # 3 bits
    lambda: unpack(np.zeros((2, 4), np.uint32), 4, np.zeros((2, 31), np.uint8)),  # wrong width
    lambda: unpack(np.zeros((2, 4), np.uint32), 4, np.zeros((3, 32), np.uint8)),  # wrong rows
    lambda: unpack(np.zeros((2, 4), np.int32), 4, np.zeros((2, 32), np.uint8)),  # signed words
    lambda: unpack(np.zeros((4, 2), np.uint32).T, 4, np.zeros((2, 32), np.uint8)),  # not contiguous
    lambda: unpack(np.zeros((2, 4), np.uint32), 4, np.zeros((2, 32), np.float64)),
    lambda: pack(np.zeros((2, 30), np.uint8), 1, 32),  # not whole words
    lambda: pack(np.zeros(30, np.uint8), 1, 8),
    lambda: pack(np.zeros((2, 32), np.uint8), 1, 32, out=np.zeros((2, 2), np.uint32)),
    lambda: digitise(np.zeros(4, np.float32), 0, 1.0, 8, np.zeros(4, np.uint8)),
    lambda: digitise(np.zeros(4, np.float32), 0, 1.0, 256, np.zeros(5, np.uint8)),
])
def test_wrong_inputs_are_value_errors(call):
    with pytest.raises(ValueError):
        call()


@pytest.mark.parametrize("levels", [2, 4, 16, 256])
def test_digitiser_codes_span_equal_steps(levels):
    a = np.linspace(0.0, 1.0, 10_001, dtype=np.float32)
    out = digitise(a, 0, 1.0, levels, np.empty(a.size, np.uint8))
    expected = np.minimum(np.floor(a.astype(np.float64) * levels), levels - 1)
    assert np.mean(out == expected) > 0.999  # (float32 rounding at a code's edge)
    assert out[0] == 0 and out[-1] == levels - 1 and np.all(np.diff(out.astype(int)) >= 0)


def test_digitiser_offset_and_gain():
    a = np.array([0.0, 0.2, 0.3, 0.5, 0.6, 1.0], dtype=np.float32)
    out = np.empty(a.size, np.uint8)
    # offset 51 (0.2 of full scale), gain ×2: (a − 0.2) · 2 → 0, 0, 0.2, 0.6, 0.8, 1 (clipped)
    np.testing.assert_array_equal(digitise(a, 51, 2.0, 256, out), [0, 0, 51, 153, 204, 255])
    # two levels: a threshold at offset + 0.5 / gain = 0.45
    np.testing.assert_array_equal(digitise(a, 51, 2.0, 2, out), [0, 0, 0, 1, 1, 1])
