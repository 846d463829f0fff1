"""Tests for vision mutants that survived the full run's fast pass (part 5; docs/testing.md):

* ``digitise_pack`` subtracts the black offset, given in 255ths of the full video level, as
  ``digitise`` does (docs/framegrabber.md);
* ``digitise_pack`` refuses, with a ValueError, any video array that is not a C-contiguous 2-D
  float32 array — before its compiled kernel sees it.
"""
import numpy as np
import pytest

from rtctl.vision.pixels import digitise, digitise_pack


@pytest.mark.parametrize("offset", [0, 51, 200])
def test_digitise_pack_subtracts_the_black_offset_in_255ths(offset):
    """Pixels 1 … 8 at 16 levels: each video level in the middle of its step, raised by the
    offset; the packed 32-bit word is 0x12345678 (the first pixel in the top nibble)."""
    codes = np.arange(1, 9, dtype=np.float64)
    analog = ((codes + 0.5) / 16 * (1 - offset / 255) + offset / 255).astype(np.float32).reshape(1, 8)
    gain = 1 / (1 - offset / 255)  # the same 16 steps over what is left above black
    out = np.zeros((1, 1), dtype="<u4")
    digitise_pack(analog, offset, gain, 16, out)
    assert hex(int(out[0, 0])) == "0x12345678"
    grey = np.zeros(analog.shape, dtype=np.uint8)
    assert digitise(analog, offset, gain, 16, grey).tolist() == [list(range(1, 9))]


@pytest.mark.parametrize("analog", [
    np.zeros((2, 8), dtype=np.float64),
    np.zeros(8, dtype=np.float32),
    np.zeros((8, 2), dtype=np.float32).T,  # not C-contiguous
    [[0.0] * 8] * 2,
], ids=["float64", "1-D", "transposed", "list"])
def test_digitise_pack_refuses_what_is_not_a_contiguous_2d_float32_array(analog):
    with pytest.raises(ValueError, match="analog must be a C-contiguous 2-D float32 array"):
        digitise_pack(analog, 0, 1.0, 16, np.zeros((2, 1), dtype="<u4"))
