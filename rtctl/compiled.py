"""The two ways rtctl compiles numerical code with numba.

``@kernel`` — a function called from Python or shared by several kernels: compiled on first
use, cached on disk (in a directory named after the sources: :mod:`rtctl.kernel_cache`), and
without numba's reference counting (``_nrt=False``).
The tick's arrays are all preallocated, so there is nothing to count; counting would cost
an atomic increment and decrement per array per call (the recursions ran 2–3× slower with it)
and a heap-allocated wrapper per array argument on every call from Python (~0.15 µs each).
A kernel that tried to allocate would not compile.

``@leaf`` — a small helper called from kernels only (the spatial products, per-link terms):
compiled once per argument types and inlined by LLVM into its callers. Unlike an ``@njit``
function it is not specialised on the constants callers pass it (a slot index, a flag), which
would compile one copy per constant; and unlike ``inline="always"`` it is typed once, not at
every call site (numba's own inlining multiplied the first run's compile time). Called from
Python it runs as plain Python, which is what tests and the operation counts use.
"""
from __future__ import annotations

from numba import njit
from numba.extending import register_jitable

leaf = register_jitable(_nrt=False)


def kernel(fn=None, /, **options):
    """``@kernel``, or ``@kernel(error_model="numpy")`` with further numba options."""
    jit = njit(cache=True, _nrt=False, **options)
    return jit if fn is None else jit(fn)
