"""Finding the bright tool marker in a box of an image (docs/framegrabber.md, "The marker").

Within the box the threshold is halfway between the brightest pixel and the box's mean; the
marker's position is the centroid of the pixels above it, each weighted by how far above it
is. On an anti-aliased (or optically blurred) disc that weighting keeps the partly covered
edge pixels in proportion, so the centroid lands on the disc's centre to a small fraction of
a pixel. Nothing is found when the box's contrast (brightest − mean) is below
``min_contrast`` (a fraction of full scale), or the box is empty.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _centroid(img, r0, r1, c0, c1, min_contrast, out):
    """out ← (row, col, weight, pixels) of the bright blob in img[r0:r1, c0:c1]; False if none."""
    total, top = 0.0, 0
    for i in range(r0, r1):
        for j in range(c0, c1):
            v = img[i, j]
            total += v
            if v > top:
                top = v
    mean = total / ((r1 - r0) * (c1 - c0))  # a box of at least one pixel (``locate``)
    if top - mean < min_contrast:
        return False
    threshold = 0.5 * (top + mean)
    sw = si = sj = 0.0
    n = 0
    for i in range(r0, r1):
        for j in range(c0, c1):
            w = img[i, j] - threshold
            if w > 0.0:
                sw += w
                si += w * i
                sj += w * j
                n += 1
    out[0], out[1], out[2], out[3] = si / sw, sj / sw, sw, n
    return True


def locate(img: np.ndarray, center, half: tuple[int, int], levels: int, min_contrast: float,
           out: np.ndarray) -> bool:
    """The marker in the box of ``half`` = (rows, cols) half-sizes around ``center`` = (row,
    col) of ``img`` (uint8 grey levels 0 … levels − 1): ``out`` ← (row, col, weight,
    pixels) in image coordinates; False when nothing stands out or the box misses the image."""
    if not isinstance(img, np.ndarray) or img.ndim != 2 or img.dtype != np.uint8:
        raise ValueError(f"img must be a 2-D uint8 array, got {getattr(img, 'shape', None)} {getattr(img, 'dtype', None)}")
    if not isinstance(out, np.ndarray) or out.shape != (4,) or out.dtype != np.float64:
        raise ValueError("out must be a float64 array of 4")
    if levels not in (2, 4, 16, 256) or not 0 < min_contrast <= 1:  # (0: a flat box's centroid has no weight)
        raise ValueError(f"levels 2/4/16/256 and min_contrast in (0, 1], got {levels}, {min_contrast}")
    row, col = center
    if not (np.isfinite(row) and np.isfinite(col)):
        return False
    rows, cols = img.shape
    r0, r1 = max(int(row) - half[0], 0), min(int(row) + half[0] + 1, rows)
    c0, c1 = max(int(col) - half[1], 0), min(int(col) + half[1] + 1, cols)
    if r0 >= r1 or c0 >= c1:
        return False
    return _centroid(img, r0, r1, c0, c1, min_contrast * (levels - 1), out)


def warm_up() -> None:
    """Compile (or load) the centroid before the loop starts: a warm-up image whose predicted
    marker falls outside the box never reaches it, and compiling it in the loop stalled a run
    for half a second (the drives' watchdog stopped them)."""
    img = np.zeros((8, 8), dtype=np.uint8)
    img[3:5, 3:5] = 255
    locate(img, (4.0, 4.0), (2, 2), 256, 0.1, np.zeros(4))
