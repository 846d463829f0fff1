"""Per-channel ARX(na, nb, d) model (Qu & Jiang, eqs. (13)-(16)):

    y(k) = Σ_{j=1..na} a_j y(k−j) + Σ_{j=0..nb} b_j u(k−d−j) + W(k)              (13)
    θ = [a_1 … a_na, b_0 … b_nb]ᵀ,  h(k) = [y(k−1) … y(k−na), u(k−d) … u(k−d−nb)]ᵀ   (14), (15)

y is a joint's position, u its torque, d ≥ 1 the dead time in samples. The history of each
channel is kept newest first: ``y_hist[j] = y(k−1−j)`` (na entries) and ``u_hist[j] =
u(k−1−j)`` (d + nb entries), so that h(k) is ``y_hist`` followed by ``u_hist[d−1:]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rtctl.compiled import kernel


# far beyond a joint's model (the paper's is n = 2, d = 1); the bound keeps P (p × p per joint)
# and the histories small: na = 100000 asked for 224 GiB
MAX_ORDER = {"na": 16, "nb": 16, "d": 64}


@dataclass(frozen=True)
class ArxOrder:
    na: int = 2
    nb: int = 2
    d: int = 1

    def __post_init__(self):
        for name, high in MAX_ORDER.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= high:
                raise ValueError(f"{name} must be an integer from 1 to {high}, got {value!r}")

    @property
    def p(self) -> int:
        """Number of coefficients, na + nb + 1."""
        return self.na + self.nb + 1

    @property
    def memory(self) -> int:
        """Length of the input history, d + nb."""
        return self.d + self.nb

    def names(self) -> list[str]:
        return [f"a{j}" for j in range(1, self.na + 1)] + [f"b{j}" for j in range(self.nb + 1)]


@kernel
def regressor_into(i, y_hist, u_hist, d, h):
    """h(k) of channel ``i`` (eq. 15) from its histories (channel-last: (na, m), (d + nb, m))."""
    na = y_hist.shape[0]
    for j in range(na):
        h[j] = y_hist[j, i]
    for j in range(h.shape[0] - na):
        h[na + j] = u_hist[d - 1 + j, i]


@kernel
def push_history(i, y_hist, u_hist, y, u):
    """Shift channel ``i``'s histories by one sample, newest first."""
    for j in range(y_hist.shape[0] - 1, 0, -1):
        y_hist[j, i] = y_hist[j - 1, i]
    y_hist[0, i] = y
    for j in range(u_hist.shape[0] - 1, 0, -1):
        u_hist[j, i] = u_hist[j - 1, i]
    u_hist[0, i] = u


def simulate(order: ArxOrder, theta, u, w, y0=None) -> np.ndarray:
    """y of the ARX plant with coefficients ``theta`` (p,) or (N, p) per sample, input ``u``
    and noise ``w`` (N,), from rest (past y = ``y0`` or 0, past u = 0). For tests and studies."""
    u, w = np.asarray(u, float), np.asarray(w, float)
    N = len(u)
    th = np.broadcast_to(np.asarray(theta, float), (N, order.p))
    y = np.zeros(N)
    y_past = np.full(order.na, 0.0 if y0 is None else float(y0))
    for k in range(N):
        acc = w[k]
        for j in range(1, order.na + 1):
            acc += th[k, j - 1] * (y[k - j] if k - j >= 0 else y_past[0])
        for j in range(order.nb + 1):
            m = k - order.d - j
            acc += th[k, order.na + j] * (u[m] if m >= 0 else 0.0)
        y[k] = acc
    return y
