"""Input checks of the public model API: a wrong shape, dtype or value is a ``ValueError`` (a
non-array a ``TypeError``) saying what was expected — never a segfault or a pose read from
memory a compiled kernel does not own.

The convenience functions check every call (:func:`vector`, :func:`matrix`). The hot-path
``*_into`` forms check their arrays once: :func:`check_into` remembers, per :class:`Data` and
per function, the arrays it last accepted and skips the check while the same ones come back
(the usual case: preallocated arrays), so a tick pays a few identity comparisons.
"""
from __future__ import annotations

import math
import operator

import numpy as np

_REAL = "iuf"  # integer, unsigned, float: what converts to float64 exactly enough
_NONE: dict = {}  # the "checked" of an object that is no Data: always checked (and refused)


def _array(x, name: str) -> np.ndarray:
    if x is None:
        raise TypeError(f"{name}: expected an array of numbers, got None")
    try:
        a = np.asarray(x)
    except (TypeError, ValueError) as e:  # ragged nesting, unconvertible objects
        raise ValueError(f"{name}: expected an array of numbers ({e})") from None
    if a.dtype.kind not in _REAL:
        raise ValueError(f"{name}: expected real numbers, got dtype {a.dtype}")
    return a


def vector(x, n: int, name: str = "q", what: str = "joint values") -> np.ndarray:
    """``x`` as a C-contiguous float64 vector of ``n`` finite numbers."""
    a = _array(x, name)
    if a.shape != (n,):
        raise ValueError(f"{name}: expected {n} {what} (shape ({n},)), got shape {a.shape}")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if not all(map(math.isfinite, a.tolist())):  # for a few values, 3x faster than np.isfinite().all()
        raise ValueError(f"{name}: expected finite values, got {a}")
    return a


def matrix(x, shape: tuple, name: str) -> np.ndarray:
    """``x`` as a C-contiguous float64 array of ``shape``, all finite."""
    a = _array(x, name)
    if a.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {a.shape}")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: expected finite values")
    return a


def number(x, name: str, *, positive: bool = False) -> float:
    """A finite real number (> 0 if ``positive``)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a number, got {type(x).__name__}")
    x = float(x)
    if not np.isfinite(x) or (positive and x <= 0):
        raise ValueError(f"{name}: expected a finite number{' > 0' if positive else ''}, got {x}")
    return x


def _kernel_array(a, shape: tuple, dtype, name: str, writeable: bool) -> None:
    if not isinstance(a, np.ndarray):
        raise TypeError(f"{name}: expected a numpy array, got {type(a).__name__}")
    if a.shape != shape or a.dtype != dtype or not a.flags.c_contiguous or (writeable and not a.flags.writeable):
        raise ValueError(f"{name}: expected a C-contiguous{' writeable' if writeable else ''} {np.dtype(dtype)} "
                         f"array of shape {shape}, got {a.dtype} {a.shape}"
                         f"{'' if a.flags.c_contiguous else ' (not contiguous)'}"
                         f"{'' if a.flags.writeable or not writeable else ' (read-only)'}")


def check_model_arrays(arrays, data) -> int:
    """n, after checking that ``arrays`` (ModelArrays) and ``data`` (Data) belong to one n-joint model."""
    joint = getattr(arrays, "joint", None)
    if not isinstance(joint, np.ndarray) or joint.ndim != 2:
        raise TypeError(f"arrays: expected ModelArrays (rtctl.model.dynamics.model_arrays), got {type(arrays).__name__}")
    n = joint.shape[0]
    _kernel_array(joint, (n, 2), np.int64, "arrays.joint", False)
    if any(not -1 <= parent < i for i, parent in enumerate(joint[:, 1].tolist())):
        raise ValueError("arrays.joint: parents must precede their children (−1 for the base)")
    _kernel_array(arrays.geom, (n, 5, 3), np.float64, "arrays.geom", False)
    _kernel_array(arrays.params, (n, 10), np.float64, "arrays.params", False)
    _kernel_array(arrays.gravity, (3,), np.float64, "arrays.gravity", False)
    X = getattr(data, "X", None)
    if not isinstance(X, np.ndarray) or X.shape != (n, 4, 3):
        raise ValueError(f"data: expected the Data of a {n}-joint model (Data(model)), "
                         f"got one for {getattr(X, 'shape', ('?',))[0]} joints")
    return n


def check_into(function: str, data, args: tuple, n_inputs: int, n_matrices: int = 0) -> None:
    """Check a ``*_into`` call unless ``data`` accepted these very objects last time.

    ``args`` is ``(arrays, *inputs, *vector_outputs, *matrix_outputs)``: ``n_inputs`` length-n
    vectors, then writeable length-n vectors, then ``n_matrices`` writeable (n, n) arrays, all
    C-contiguous float64. The fast path is a dict lookup and one identity test per argument.
    """
    seen = getattr(data, "checked", _NONE).get(function, ())
    if len(seen) == len(args) and all(map(operator.is_, seen, args)):
        return
    n = check_model_arrays(args[0], data)
    names = ("q", "qd", "qdd", "tau", "armature")
    last_vector = len(args) - n_matrices
    for i, a in enumerate(args[1:], start=1):
        if i <= n_inputs:
            _kernel_array(a, (n,), np.float64, names[i - 1], False)
        else:
            _kernel_array(a, (n,) if i < last_vector else (n, n), np.float64, "output", True)
    data.checked[function] = args
