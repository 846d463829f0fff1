"""The compiled algorithms' inputs: packed model arrays and the Data workspace (Pinocchio's
model/data split).

Every array handed to a numba kernel from Python costs ~0.15 µs to unbox, so the model and the
workspace are packed into a few arrays:

``ModelArrays`` (read-only, from :func:`model_arrays`)
    ``joint``   (n, 2) int64   — joint type (REVOLUTE/PRISMATIC), parent index (−1 = base)
    ``geom``    (n, 5, 3)      — joint axis, R_tree (3 rows), p_tree, in the parent body
    ``params``  (n, 10)        — inertial parameters, Pinocchio's order (swap for estimates
                                 with ``arrays._replace(params=p)``)
    ``gravity`` (3,)           — gravity acceleration in base coordinates

``Data`` (scratch, one per user; overwritten by every call)
    ``X``    (n, 4, 3)  — ⁱX_λ(q) as (E, r): rows 0–2 E, row 3 r (see spatial_kernels)
    ``body`` (n, 9, 6)  — per body: S (motion subspace), v, u (reference velocity), w
                          (acceleration), f, and 4 scratch vectors from TMP on
                          (:mod:`rtctl.model.recursions` says who writes what)
    ``Ic``   (n, 10)    — composite inertias (CRBA)
    ``H``    (n, n)     — mass matrix (forward dynamics factorises it in place)
    ``bias`` (n,), ``zero`` (n,) — C q̇ + G; a zero vector
    ``I6``, ``B6`` (n, 6, 6), ``M6`` (2, 6, 6) — composite 6×6 terms of C and Ḣ, scratch
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rtctl.model.robot import Model

SUB, VEL, REF, ACC, FRC, TMP = 0, 1, 2, 3, 4, 5  # slots of Data.body; TMP .. TMP + 3 are scratch
BODY_SLOTS = TMP + 4


class ModelArrays(NamedTuple):
    joint: np.ndarray
    geom: np.ndarray
    params: np.ndarray
    gravity: np.ndarray


def model_arrays(model: Model) -> ModelArrays:
    """Pack a Model for the kernels (C-contiguous float64/int64 copies)."""
    n = model.nq
    geom = np.empty((n, 5, 3))
    geom[:, 0] = model.axis
    geom[:, 1:4] = model.R_tree
    geom[:, 4] = model.p_tree
    return ModelArrays(
        joint=np.ascontiguousarray(np.stack([model.joint_types, model.parent], axis=1), dtype=np.int64),
        geom=geom,
        params=np.array(model.params, dtype=float),
        gravity=np.array(model.gravity, dtype=float),
    )


class Data:
    """Preallocated workspace for one model (see the module docstring for the arrays)."""

    __slots__ = ("X", "body", "Ic", "H", "bias", "zero", "I6", "B6", "M6", "checked")

    def __init__(self, model: Model):
        n = model.nq
        self.X = np.zeros((n, 4, 3))
        self.body = np.zeros((n, BODY_SLOTS, 6))
        self.Ic = np.zeros((n, 10))
        self.H = np.zeros((n, n))
        self.bias = np.zeros(n)
        self.zero = np.zeros(n)
        self.I6 = np.zeros((n, 6, 6))
        self.B6 = np.zeros((n, 6, 6))
        self.M6 = np.zeros((2, 6, 6))
        self.checked = {}  # per *_into function: the arrays it last accepted (rtctl.model.checks)
