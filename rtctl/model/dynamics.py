"""Rigid-body dynamics of a serial chain (docs/cstar_slotine_li.md):

    H(q) q̈ + C(q, q̇) q̇ + G(q) = τ

Two forms of every per-tick algorithm, as Pinocchio splits model and data:

**Convenience API** — pure functions over (model, state) returning new arrays; each call
allocates a workspace and its result (~10–20 µs), so use it in scripts and tests, not in a loop:
``rnea``, ``mass_matrix``, ``gravity``, ``coriolis_matrix(kind)``, ``mass_matrix_dot``,
``regressor``, ``slotine_li_regressor(kind)``, ``forward_dynamics``.

**Hot path** — allocation-free numba kernels over preallocated arrays::

    arrays = model_arrays(model)   # ModelArrays: joint (n,2) int, geom (n,5,3), params (n,10), gravity (3,)
    data = Data(model)             # workspace: X, body, Ic, H, … (see rtctl.model.data)
    rnea_into(arrays, data, q, qd, qdd, tau_out)                 # τ = H q̈ + C q̇ + G
    gravity_into(arrays, data, q, g_out)                         # G(q)
    mass_matrix_into(arrays, data, q, H_out)                     # H(q), (n, n)
    bias_into(arrays, data, q, qd, b_out)                        # C q̇ + G
    forward_dynamics_into(arrays, data, q, qd, tau, armature, qdd_out)   # (H + diag(armature)) q̈ = τ − C q̇ − G
    coriolis_matrix_into(arrays, data, q, qd, kind, C_out)       # kind: CHRISTOFFEL or CSTAR

All vectors are C-contiguous float64 of length n (armature: zeros for none); each ``*_into``
checks its arrays (shapes, dtypes, that ``data`` fits ``arrays``) the first time it sees them
with a ``data`` and raises ValueError, so a wrong size is never a segfault
(:mod:`rtctl.model.checks`). Each ``*_into`` unpacks the arrays and calls one kernel (``rnea_kernel``, ``crba_kernel``,
``forward_dynamics_kernel``, ``coriolis_kernel`` in the algorithm modules), costing ~1–2 µs of
numba dispatch from Python. Code that is itself compiled (a simulator's substep loop, a
controller's recursion) should call the kernels — or the passes and the spatial kernels
(:mod:`rtctl.model.spatial_kernels`) — directly, with no dispatch at all. To run the same
algorithms with estimated parameters, use ``arrays._replace(params=p_hat)``.

Algorithms: RNEA (:mod:`rtctl.model.rnea`, Featherstone Table 5.1), CRBA
(:mod:`rtctl.model.crba`, Table 6.2), forward dynamics by CRBA + Cholesky
(:mod:`rtctl.model.forward_dynamics`), C in both factorisations and Ḣ
(:mod:`rtctl.model.coriolis`, the paper's eq. 9 and its Christoffel counterpart), the
regressors (:mod:`rtctl.model.regressor`, eq. 17).
"""
from __future__ import annotations

import weakref

import numpy as np

from rtctl.model.coriolis import CHRISTOFFEL, CSTAR, coriolis_kernel, mass_matrix_dot_kernel
from rtctl.model.crba import crba_kernel
from rtctl.model.checks import check_into, vector
from rtctl.model.data import Data, ModelArrays, model_arrays
from rtctl.model.forward_dynamics import forward_dynamics_kernel
from rtctl.model.regressor import regressor, slotine_li_regressor
from rtctl.model.rnea import rnea_kernel
from rtctl.model.robot import Model

__all__ = [
    "rnea", "mass_matrix", "gravity", "coriolis_matrix", "mass_matrix_dot", "regressor",
    "slotine_li_regressor", "forward_dynamics", "Data", "ModelArrays", "model_arrays",
    "rnea_into", "gravity_into", "mass_matrix_into", "bias_into", "forward_dynamics_into",
    "coriolis_matrix_into", "CHRISTOFFEL", "CSTAR",
]

_KINDS = {"christoffel": CHRISTOFFEL, "cstar": CSTAR}
_SINGULAR = ("H(q) + diag(armature) is not positive definite at this q "
             "(a joint with no inertia and no armature, or non-physical parameters)")


# --- hot path -------------------------------------------------------------------------------

def rnea_into(arrays: ModelArrays, data: Data, q, qd, qdd, tau) -> None:
    """τ = H(q) q̈ + C(q, q̇) q̇ + G(q) into ``tau`` (RNEA)."""
    check_into("rnea", data, (arrays, q, qd, qdd, tau), 3)
    rnea_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, q, qd, qdd, tau)


def gravity_into(arrays: ModelArrays, data: Data, q, g) -> None:
    """G(q) into ``g`` (RNEA with q̇ = q̈ = 0)."""
    check_into("gravity", data, (arrays, q, g), 1)
    rnea_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, q,
                data.zero, data.zero, g)


def bias_into(arrays: ModelArrays, data: Data, q, qd, b) -> None:
    """C(q, q̇) q̇ + G(q) into ``b`` (RNEA with q̈ = 0)."""
    check_into("bias", data, (arrays, q, qd, b), 2)
    rnea_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, q, qd,
                data.zero, b)


def mass_matrix_into(arrays: ModelArrays, data: Data, q, H) -> None:
    """H(q) into the (n, n) array ``H`` (CRBA)."""
    check_into("mass_matrix", data, (arrays, q, H), 1, 1)
    crba_kernel(arrays.joint, arrays.geom, arrays.params, data.X, data.body, data.Ic, q, H)


def forward_dynamics_into(arrays: ModelArrays, data: Data, q, qd, tau, armature, qdd) -> None:
    """q̈ = (H + diag(armature))⁻¹ (τ − C q̇ − G) into ``qdd`` (CRBA + Cholesky)."""
    check_into("forward_dynamics", data, (arrays, q, qd, tau, armature, qdd), 4)
    try:
        forward_dynamics_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body,
                                data.Ic, data.H, q, qd, tau, armature, qdd)
    except ZeroDivisionError:  # a zero pivot: no inertia and no armature on some joint
        raise ValueError(_SINGULAR) from None


def coriolis_matrix_into(arrays: ModelArrays, data: Data, q, qd, kind: int, C) -> None:
    """C(q, q̇) into the (n, n) array ``C``; ``kind`` is CHRISTOFFEL or CSTAR."""
    if kind != CHRISTOFFEL and kind != CSTAR:
        raise ValueError(f"kind: expected CHRISTOFFEL ({CHRISTOFFEL}) or CSTAR ({CSTAR}), got {kind!r}")
    check_into("coriolis_matrix", data, (arrays, q, qd, C), 2, 1)
    coriolis_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, data.Ic, data.I6,
                    data.B6, data.M6, q, qd, data.zero, kind, C)


# --- convenience API ------------------------------------------------------------------------

_PACKED: "weakref.WeakKeyDictionary[Model, ModelArrays]" = weakref.WeakKeyDictionary()


def _setup(model: Model, *vectors):
    """Packed arrays (cached per Model: it is immutable), a fresh workspace, checked vectors:
    the convenience functions call the kernels directly, everything they pass is checked or theirs."""
    arrays = _PACKED.get(model)
    if arrays is None:
        arrays = _PACKED[model] = model_arrays(model)
    names = ("q", "qd", "qdd" if len(vectors) == 3 else "tau")
    return (arrays, Data(model), *(vector(v, model.nq, name) for v, name in zip(vectors, names)))


def rnea(model: Model, q, qd, qdd) -> np.ndarray:
    """Inverse dynamics τ = H q̈ + C q̇ + G (Featherstone Table 5.1)."""
    arrays, data, q, qd, qdd = _setup(model, q, qd, qdd)
    tau = np.zeros(model.nq)
    rnea_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, q, qd, qdd, tau)
    return tau


def gravity(model: Model, q) -> np.ndarray:
    """Generalised gravity G(q)."""
    arrays, data, q = _setup(model, q)
    g = np.zeros(model.nq)
    rnea_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, q, data.zero,
                data.zero, g)
    return g


def mass_matrix(model: Model, q) -> np.ndarray:
    """Joint-space mass matrix H(q) (CRBA, Featherstone Table 6.2)."""
    arrays, data, q = _setup(model, q)
    H = np.zeros((model.nq, model.nq))
    crba_kernel(arrays.joint, arrays.geom, arrays.params, data.X, data.body, data.Ic, q, H)
    return H


def coriolis_matrix(model: Model, q, qd, kind: str = "christoffel") -> np.ndarray:
    """C(q, q̇) in one of the two factorisations of docs/cstar_slotine_li.md:

    * ``"christoffel"`` — c_ij = Σ_k c_ijk q̇_k from the Christoffel symbols (paper eq. 2;
      Pinocchio's ``computeCoriolisMatrix``);
    * ``"cstar"`` — the paper's C* (eq. 9), body-level factorisation v ×* I v = (crf(v) I) v.

    Both satisfy C q̇ = RNEA(q, q̇, 0) − G and Ḣ = C + Cᵀ (Proposition 2); they differ for
    chains of three or more joints (Proposition 1).
    """
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {sorted(_KINDS)}, got {kind!r}")
    arrays, data, q, qd = _setup(model, q, qd)
    C = np.zeros((model.nq, model.nq))
    coriolis_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, data.Ic, data.I6,
                    data.B6, data.M6, q, qd, data.zero, _KINDS[kind], C)
    return C


def mass_matrix_dot(model: Model, q, qd) -> np.ndarray:
    """Ḣ(q, q̇) = dH/dt along q̇, from the time derivatives of the composite inertias."""
    arrays, data, q, qd = _setup(model, q, qd)
    Hd = np.zeros((model.nq, model.nq))
    mass_matrix_dot_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body, data.Ic,
                           data.I6, data.B6, data.M6, q, qd, data.zero, Hd)
    return Hd


def forward_dynamics(model: Model, q, qd, tau, armature=None) -> np.ndarray:
    """q̈ from (H + diag(armature)) q̈ = τ − C q̇ − G; ``armature`` (≥ 0) defaults to none (zeros).
    ValueError where H + diag(armature) is not positive definite (non-physical parameters)."""
    arrays, data, q, qd, tau = _setup(model, q, qd, tau)
    armature = np.zeros(model.nq) if armature is None else vector(armature, model.nq, "armature")
    if np.any(armature < 0):
        raise ValueError(f"armature: expected values ≥ 0, got {armature}")
    qdd = np.zeros(model.nq)
    try:
        forward_dynamics_kernel(arrays.joint, arrays.geom, arrays.params, arrays.gravity, data.X, data.body,
                                data.Ic, data.H, q, qd, tau, armature, qdd)
    except ZeroDivisionError:
        raise ValueError(f"{model.name}: {_SINGULAR}") from None
    if not np.all(np.isfinite(qdd)):  # the Cholesky factorisation met a negative pivot
        raise ValueError(f"{model.name}: {_SINGULAR}")
    return qdd
