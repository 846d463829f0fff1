"""Tests for vision mutants that survived the fast pass of the restarted full run
(docs/mutation/vision.md, part 14): ``locate``'s output is four float64 numbers, refused
otherwise whatever its type (an ``and`` for an ``or`` let a float64 array of another shape
through to the compiled centroid, which writes four elements)."""
import numpy as np
import pytest

from rtctl.vision.marker import locate


@pytest.mark.parametrize("out", [np.zeros(3), np.zeros(5), np.zeros((4, 1)), [0.0] * 4],
                         ids=["3", "5", "4x1", "list"])
def test_locate_refuses_an_out_that_is_not_four_float64s(out):
    img = np.zeros((8, 8), dtype=np.uint8)
    img[3:5, 3:5] = 255
    with pytest.raises(ValueError, match="float64 array of 4"):
        locate(img, (4.0, 4.0), (2, 2), 256, 0.1, out)
