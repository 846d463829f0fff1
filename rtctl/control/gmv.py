"""Generalised minimum-variance (GMV) control of an ARX model (Qu & Jiang, eqs. (28)-(30)).

d-step predictor with the current estimates θ̂ = [â_1 … â_na, b̂_0 … b̂_nb] and r̂ (eq. 28)::

    ŷ(k+j|k) = Σ_m â_m ŷ(k+j−m|k) + Σ_m b̂_m u(k+j−d−m) + r̂,   j = 1 … d,
    ŷ(k+j−m|k) = y(k+j−m) where k+j−m ≤ k.

ŷ(k+d|k) is affine in u(k): ŷ(k+d|k) = b̂_0 u(k) + φ(k) (:func:`gmv_phi` computes φ with
u(k) = 0). Minimising J = E{(y(k+d) − y*(k+d))² + ρ (u(k) − u(k−1))²} (29) gives (30)::

    u(k) = [ b̂_0 (y*(k+d) − φ(k)) + ρ u(k−1) ] / (b̂_0² + ρ)

saturated at ±u_max (:func:`gmv_law`); the caller keeps the *saturated* value as u(k−1) for the
next sample, which is the anti-windup. With an exact model, ρ (u(k) − u(k−1)) = b̂_0 (y* − ŷ(k+d|k)),
and the closed-loop characteristic polynomial is B(z⁻¹) + (ρ/b_0)(1 − z⁻¹) A(z⁻¹), A = 1 − Σ a_j z⁻ʲ
(Clarke & Gawthrop 1975; tests/control/test_gmv.py checks both against numpy polynomials).
Histories are channel-last and newest first, as in :mod:`rtctl.estimation.arx`.
"""
from __future__ import annotations

import math

import numpy as np

from rtctl.compiled import kernel
from rtctl.estimation.arx import ArxOrder


@kernel
def gmv_phi(i, theta, r_hat, y, y_hist, u_hist, na, d, y_pred):
    """φ(k) of channel ``i``: the d-step prediction (28) with u(k) = 0. ``y_pred``: scratch (≥ d)."""
    nb1 = theta.shape[0] - na
    for j in range(1, d + 1):
        acc = r_hat
        for m in range(1, na + 1):
            rel = j - m  # sample k + rel
            if rel >= 1:
                acc += theta[m - 1, i] * y_pred[rel - 1]
            elif rel == 0:
                acc += theta[m - 1, i] * y
            else:
                acc += theta[m - 1, i] * y_hist[-rel - 1, i]
        for m in range(nb1):
            rel = j - d - m
            if rel < 0:  # rel = 0 is u(k) itself, the unknown
                acc += theta[na + m, i] * u_hist[-rel - 1, i]
        y_pred[j - 1] = acc
    return y_pred[d - 1]


@kernel(error_model="numpy")  # 0/0 → NaN, caught by the caller
def gmv_law(b0, phi, y_star, rho, u_prev, u_max):
    """u(k) of (30), saturated at ±u_max (NaN stays NaN for the caller to catch)."""
    u = (b0 * (y_star - phi) + rho * u_prev) / (b0 * b0 + rho)
    if u > u_max:
        return u_max
    if u < -u_max:
        return -u_max
    return u


def gmv_control(theta, r_hat: float, y: float, y_hist, u_hist, order: ArxOrder, y_star: float, rho: float,
                u_max: float = math.inf) -> float:
    """u(k) for one channel: ``theta`` (p,), ``y_hist`` = [y(k−1) … y(k−na)], ``u_hist`` =
    [u(k−1) … u(k−d−nb)]. Checks its inputs; the controller calls the kernels directly."""
    theta = np.ascontiguousarray(theta, dtype=float).reshape(-1, 1)
    y_hist = np.ascontiguousarray(y_hist, dtype=float).reshape(-1, 1)
    u_hist = np.ascontiguousarray(u_hist, dtype=float).reshape(-1, 1)
    if theta.shape[0] != order.p or y_hist.shape[0] != order.na or u_hist.shape[0] != order.memory:
        raise ValueError(f"need θ of {order.p}, {order.na} past outputs and {order.memory} past inputs, got "
                         f"{theta.shape[0]}, {y_hist.shape[0]}, {u_hist.shape[0]}")
    if not rho > 0 or not u_max > 0:
        raise ValueError(f"rho and u_max must be > 0, got {rho!r}, {u_max!r}")
    phi = gmv_phi(0, theta, float(r_hat), float(y), y_hist, u_hist, order.na, order.d, np.zeros(order.d))
    return float(gmv_law(theta[order.na, 0], phi, float(y_star), float(rho), u_hist[0, 0], float(u_max)))
