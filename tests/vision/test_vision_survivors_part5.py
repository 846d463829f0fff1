"""Tests for vision mutants that survived the full run's fast pass (part 5; docs/mutation/vision.md):

* ``digitise_pack`` subtracts the black offset, given in 255ths of the full video level, as
  ``digitise`` does (docs/framegrabber.md);
* ``digitise_pack`` refuses, with a ValueError, any video array that is not a C-contiguous 2-D
  float32 array, an offset outside 0…255 and levels other than 2, 4, 16, 256 — before its
  compiled kernel sees them;
* the marker's ``min_contrast`` is a fraction of the full grey scale, levels − 1;
* ``digitise`` refuses an ``out`` array that is not C-contiguous uint8 of the video's shape;
* a device's slot stride must hold the slot header and the data;
* a camera's ``up`` is world +z unless the table gives one (of 3 numbers).
"""
import numpy as np
import pytest

from rtctl.vision.marker import locate
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


@pytest.mark.parametrize("offset, levels", [(256, 16), (-1, 16), (0, 3), (0, 8)])
def test_digitise_pack_refuses_an_offset_or_levels_out_of_range(offset, levels):
    with pytest.raises(ValueError, match="levels 2/4/16/256, offset 0..255"):
        digitise_pack(np.zeros((1, 8), dtype=np.float32), offset, 1.0, levels, np.zeros((1, 1), dtype="<u4"))


@pytest.mark.parametrize("peak, found", [(3, False), (4, True)])
def test_min_contrast_is_a_fraction_of_levels_minus_one(peak, found):
    """16 levels, min_contrast 0.2: a peak must stand 0.2 · 15 = 3 grey levels above the box's
    mean. A 5 × 5 box of zeros around one pixel of ``peak``: it stands 24/25 · peak above."""
    img = np.zeros((9, 9), dtype=np.uint8)
    img[4, 4] = peak  # 2.88 levels above the mean: not enough; 3.84: enough
    out = np.zeros(4)
    assert locate(img, (4, 4), (2, 2), 16, 0.2, out) == found


def test_digitise_refuses_an_out_array_that_does_not_match():
    analog = np.zeros((2, 8), dtype=np.float32)
    for out in (np.zeros((2, 8), dtype=np.uint16), np.zeros((2, 4), dtype=np.uint8), np.zeros((8, 2), dtype=np.uint8).T,
                [[0] * 8] * 2):
        with pytest.raises(ValueError, match=r"out must be C-contiguous uint8 of shape \(2, 8\)"):
            digitise(analog, 0, 1.0, 16, out)


def test_a_slot_stride_too_small_for_its_header_and_data_is_refused():
    from drivers.protocols.framegrabber import SLOT_HEADER_BYTES, GrabberMemory, buffer_bytes
    from rtctl.errors import ProtocolError

    buffer = np.zeros(buffer_bytes(), dtype=np.uint8)
    memory = GrabberMemory(buffer, create=True)
    data = int(memory.layout[3])
    memory.layout[2] = SLOT_HEADER_BYTES + data - 8  # a multiple of 8, one word short
    with pytest.raises(ProtocolError, match=f"slot stride {SLOT_HEADER_BYTES + data - 8} "
                                            f"\\(at least {SLOT_HEADER_BYTES + data},"):
        GrabberMemory(buffer)


@pytest.mark.parametrize("up", [None, [0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])
def test_a_cameras_up_is_world_z_unless_given(up):
    """docs: ``up`` (default +z). A point straight above the looked-at one appears straight
    above the screen's centre: same column, a smaller row."""
    from rtctl.tomltable import Table
    from rtctl.vision.camera import Camera

    target = np.array([0.35, 0.05, 0.0])
    options = {"position": [1.7, -1.2, 0.9], "look_at": target.tolist(), "focal_px": 760.0}
    if up is not None:
        options["up"] = up
    camera = Camera.from_table(Table(options, "camera.toml", "camera"))
    u, v = camera.project(target + [0.0, 0.0, 0.1])
    assert u == pytest.approx(255.5, abs=1e-9) and v < 255.5 - 10
