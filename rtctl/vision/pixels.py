"""The interface's digitiser and its packing of pixels into words (docs/framegrabber.md).

**Digitiser** (the ADC after offset and gain): a video level ``a`` in [0, 1] (black … white)
becomes the grey level ``floor(clip((a − offset/255) · 2^((gain − 128)/64), 0, 1) · L)``,
clipped to L − 1, for L = 2, 4, 16 or 256 levels (each code spans 1/L of the range; with two
levels the offset and gain set a threshold).

**Bit order.** Pixels of ``bits`` = 1, 2, 4 or 8 are packed into 8-, 16- or 32-bit words,
each image row into whole words. Within a word the *first* pixel occupies the *most
significant* bits, so a word printed in hex reads left to right: the 4-bit pixels
1, 2, …, 8 make the 32-bit word ``0x12345678``. Words are stored little-endian (the PC bus
the paper's interface sits on), so in memory that word is the bytes ``78 56 34 12``.

Unpacking is one compiled table lookup per byte (each byte → its 8/bits pixels at once) with
the byte order of the word folded into the index (``i ^ (word_bytes − 1)``); 8-bit pixels
are a byte-swapping copy. Both write into a caller's array and allocate nothing.
"""
from __future__ import annotations

import numpy as np
from numba import njit

BITS = (1, 2, 4, 8)
WORD_DTYPES = {8: np.dtype("<u1"), 16: np.dtype("<u2"), 32: np.dtype("<u4")}


def _tables() -> dict[int, np.ndarray]:
    """bits → table of 256 entries: byte value → its pixels, first pixel in the lowest byte
    of the entry (so a little-endian view of the output receives them in order)."""
    b = np.arange(256)
    out = {}
    for bits in (1, 2, 4):
        ppb, mask = 8 // bits, (1 << bits) - 1
        pix = np.stack([(b >> (8 - bits * (k + 1))) & mask for k in range(ppb)], axis=1).astype(np.uint8)
        out[bits] = np.ascontiguousarray(pix).view(np.dtype(f"<u{ppb}")).reshape(256)
    return out


_TABLES = _tables()


@njit(cache=True)
def _unpack_bytes(src, flip, table, dst):
    """dst[i] ← the pixels of byte i in MSB-first order (byte i ^ flip in memory)."""
    for i in range(src.shape[0]):
        dst[i] = table[src[i ^ flip]]


@njit(cache=True)
def _pack_bytes(pixels, bits, flip, dst):
    """dst[i ^ flip] ← the 8/bits pixels starting at pixels[i·8/bits], first in the MSBs."""
    ppb, mask = 8 // bits, (1 << bits) - 1
    for i in range(dst.shape[0]):
        v = 0
        for k in range(ppb):
            v = (v << bits) | (pixels[i * ppb + k] & mask)
        dst[i ^ flip] = v


@njit(cache=True)
def _digitise(analog, black, scale, top, out):
    """out ← min(max((analog − black) · scale, 0), top), truncated (branch-free: vectorises)."""
    b, s, t = np.float32(black), np.float32(scale), np.float32(top)
    for i in range(analog.shape[0]):
        v = (analog[i] - b) * s
        if v < 0:
            v = np.float32(0)
        if v > t:
            v = t
        out[i] = np.uint8(v)


@njit(cache=True)
def _digitise_pack(analog, black, scale, top, bits, flip, dst):
    """The digitiser and the packing in one pass: dst[i ^ flip] ← the codes of the 8/bits
    video levels starting at analog[i·8/bits], first in the MSBs."""
    ppb = 8 // bits
    b, s, t = np.float32(black), np.float32(scale), np.float32(top)
    for i in range(dst.shape[0]):
        v = 0
        for k in range(ppb):
            x = (analog[i * ppb + k] - b) * s
            if x < 0:
                x = np.float32(0)
            if x > t:
                x = t
            v = (v << bits) | int(x)
        dst[i ^ flip] = v


def digitise_pack(analog: np.ndarray, offset: int, gain_factor: float, levels: int, words: np.ndarray) -> np.ndarray:
    """Video levels (rows, width) float32 → grey levels packed into ``words`` (rows,
    words_per_row), as :func:`digitise` then :func:`pack` would, in one pass."""
    word_bits = _check_words(words)
    if not isinstance(analog, np.ndarray) or analog.dtype != np.float32 or analog.ndim != 2 \
            or not analog.flags.c_contiguous:
        raise ValueError("analog must be a C-contiguous 2-D float32 array")
    bits = {2: 1, 4: 2, 16: 4, 256: 8}.get(levels)
    if bits is None or not 0 <= offset <= 255 or not gain_factor > 0:
        raise ValueError(f"levels 2/4/16/256, offset 0..255, gain > 0; got {levels}, {offset}, {gain_factor}")
    if words.shape[0] != analog.shape[0] or words.shape[1] * word_bits != analog.shape[1] * bits:
        raise ValueError(f"{words.shape} words of {word_bits} bits do not hold {analog.shape} pixels of {bits} bits")
    _digitise_pack(analog.reshape(-1), offset / 255.0, float(gain_factor) * levels, levels - 1, bits,
                   word_bits // 8 - 1, words.view(np.uint8).reshape(-1))
    return words


def _check_words(words: np.ndarray) -> int:
    if not isinstance(words, np.ndarray) or words.ndim != 2 or words.dtype not in WORD_DTYPES.values():
        raise ValueError(f"words must be a 2-D array of little-endian uint8/16/32, got "
                         f"{getattr(words, 'shape', None)} {getattr(words, 'dtype', type(words).__name__)}")
    if not words.flags.c_contiguous:
        raise ValueError("words must be C-contiguous (rows of whole words)")
    return words.dtype.itemsize * 8


def _check_pixels(pixels: np.ndarray, name: str) -> None:
    if not isinstance(pixels, np.ndarray) or pixels.ndim != 2 or pixels.dtype != np.uint8:
        raise ValueError(f"{name} must be a 2-D uint8 array, got {getattr(pixels, 'shape', None)} "
                         f"{getattr(pixels, 'dtype', type(pixels).__name__)}")
    if not pixels.flags.c_contiguous:
        raise ValueError(f"{name} must be C-contiguous")


def _check_bits(bits: int) -> None:
    if bits not in BITS:
        raise ValueError(f"bits per pixel must be 1, 2, 4 or 8, got {bits!r}")


def unpack(words: np.ndarray, bits: int, out: np.ndarray) -> np.ndarray:
    """Packed ``words`` (rows, words_per_row) → grey levels in ``out`` (rows, width) uint8."""
    _check_bits(bits)
    word_bits = _check_words(words)
    _check_pixels(out, "out")
    rows, width = out.shape
    if words.shape[0] != rows or words.shape[1] * word_bits != width * bits:
        raise ValueError(f"{words.shape} words of {word_bits} bits do not hold {rows} × {width} pixels of {bits} bits")
    flip = word_bits // 8 - 1
    if bits == 8:  # a byte per pixel: only the byte order within the word changes
        src = words.view(np.uint8)
        np.copyto(out.view(WORD_DTYPES[word_bits]), src.view(WORD_DTYPES[word_bits].newbyteorder(">")))
        return out
    table = _TABLES[bits]
    _unpack_bytes(words.view(np.uint8).reshape(-1), flip, table, out.reshape(-1).view(table.dtype))
    return out


def pack(pixels: np.ndarray, bits: int, word_bits: int, out: np.ndarray | None = None) -> np.ndarray:
    """Grey levels (rows, width) uint8, each < 2^bits → words (rows, width·bits/word_bits).
    A level's higher bits are dropped: they never reach its neighbours' bits."""
    _check_bits(bits)
    _check_pixels(pixels, "pixels")
    if word_bits not in WORD_DTYPES:
        raise ValueError(f"word_bits must be 8, 16 or 32, got {word_bits!r}")
    rows, width = pixels.shape
    if (width * bits) % word_bits:
        raise ValueError(f"a row of {width} pixels of {bits} bits is not whole {word_bits}-bit words")
    shape = (rows, width * bits // word_bits)
    if out is None:
        out = np.empty(shape, dtype=WORD_DTYPES[word_bits])
    elif _check_words(out) != word_bits or out.shape != shape:
        raise ValueError(f"out must be {shape} of {WORD_DTYPES[word_bits]}, got {out.shape} {out.dtype}")
    flip = word_bits // 8 - 1
    if bits == 8:
        np.copyto(out.view(np.uint8).view(WORD_DTYPES[word_bits].newbyteorder(">")),
                  pixels.view(WORD_DTYPES[word_bits]))
    else:
        _pack_bytes(pixels.reshape(-1), bits, flip, out.view(np.uint8).reshape(-1))
    return out


def digitise(analog: np.ndarray, offset: int, gain_factor: float, levels: int, out: np.ndarray) -> np.ndarray:
    """Video levels (float32/64, any shape, C-contiguous) → grey levels in ``out`` (uint8, same shape)."""
    if not isinstance(analog, np.ndarray) or analog.dtype not in (np.float32, np.float64) or not analog.flags.c_contiguous:
        raise ValueError("analog must be a C-contiguous float32/float64 array")
    if not isinstance(out, np.ndarray) or out.shape != analog.shape or out.dtype != np.uint8 or not out.flags.c_contiguous:
        raise ValueError(f"out must be C-contiguous uint8 of shape {analog.shape}")
    if levels not in (2, 4, 16, 256) or not 0 <= offset <= 255 or not gain_factor > 0:
        raise ValueError(f"levels 2/4/16/256, offset 0..255, gain > 0; got {levels}, {offset}, {gain_factor}")
    _digitise(analog.reshape(-1), offset / 255.0, float(gain_factor) * levels, levels - 1, out.reshape(-1))
    return out


def warm_up() -> None:
    """Load the compiled kernels (from numba's cache) before the loop starts."""
    px = np.zeros((1, 32), dtype=np.uint8)
    for bits in (1, 2, 4):
        unpack(pack(px, bits, 32), bits, px)
    digitise(np.zeros(4, dtype=np.float32), 0, 1.0, 256, np.zeros(4, dtype=np.uint8))
    digitise_pack(np.zeros((1, 32), dtype=np.float32), 0, 1.0, 2, np.zeros((1, 1), dtype=np.uint32))
