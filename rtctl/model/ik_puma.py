"""Closed-form inverse kinematics of PUMA-type arms (Paul, Shimano & Mayer 1981; docs/kinematics.md).

A PUMA-type arm is a 6-joint revolute D-H chain (Paul's convention, eq. 1) with
|sin α₁| = 1, α₂ = 0 (shoulder and elbow axes parallel), |sin α₃| = |sin α₄| = |sin α₅| = 1 and
a₄ = a₅ = d₅ = 0 (spherical wrist: axes 4, 5, 6 meet at the wrist centre); a shoulder offset
d₂ + d₃, an elbow offset a₃, any d₁, a₁, θ0, and any a₆, d₆, α₆ and tool (they sit in the flange
and tool frames, removed first as in the paper's eq. 19). Angles here are the D-H θᵢ = qᵢ + θ0ᵢ.

Position (joints 1-3) from the wrist centre p (origin of D-H frame 4):
* z₁ is horizontal and p lies at height d₂ + d₃ along it: r sin(θ₁ − φ) = sin α₁ (d₂ + d₃)
  with (r, φ) the polar form of (pₓ, p_y): two θ₁ (arm right/left);
* in frame 1 the wrist is Rot(z, θ₂) u(θ₃) with u = (a₂ + a₃c₃ + e s₃, a₃s₃ − e c₃),
  e = sin α₃ d₄: |u|² gives a₃c₃ + e s₃ = ρ cos(θ₃ − ψ), two θ₃ (elbow up/down);
* θ₂ = atan2(p¹_y, p¹_x) − atan2(u_y, u_x).
Orientation (joints 4-6): W = R₃ᵀ R_body6 = Rot(z,θ₄) Rot(x,α₄) Rot(z,θ₅) Rot(x,α₅) Rot(z,q₆); its
third column is (s₅ sθ₅ cθ₄, s₅ sθ₅ sθ₄, −s₄ s₅ cθ₅) (sᵢ = sin αᵢ): two (θ₄, θ₅) (wrist
noflip/flip), then q₆ from what is left. At sin θ₅ = 0 (wrist singularity) only θ₄ ± q₆ is
defined; θ₄ is then taken from the seed (or q₄ = 0).

Configurations (geometric, so they hold for any sign convention of the table):
* arm RIGHT: seen from above, with the wrist ahead, the shoulder offset points to the right
  (the upper arm is on the right of the waist axis, as a human right arm);
* elbow UP: the elbow lies above the shoulder-wrist line, "above" taken with the arm's own
  forward direction (for a forward reach: higher than the line);
* wrist NOFLIP: sin θ₅ ≥ 0; FLIP is the other wrist solution (θ₄ + π, −θ₅, q₆ + π).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from rtctl.errors import KinematicsError
from rtctl.model import checks
from rtctl.model.robot import REVOLUTE, Model
from rtctl.model.rotations import rot_x, rot_z

_EXACT = 1e-12  # structural tests on the D-H table
_REACH = 1e-9  # relative slack before a pose is declared out of reach


class Arm(Enum):
    RIGHT = "r"
    LEFT = "l"


class Elbow(Enum):
    UP = "u"
    DOWN = "d"


class Wrist(Enum):
    NOFLIP = "n"
    FLIP = "f"


@dataclass(frozen=True)
class ArmConfig:
    """One of the 8 branches of a PUMA-type arm; ``ArmConfig.parse("lun")`` as in Corke's toolbox."""

    arm: Arm = Arm.RIGHT
    elbow: Elbow = Elbow.UP
    wrist: Wrist = Wrist.NOFLIP

    @classmethod
    def parse(cls, code: str) -> "ArmConfig":
        code = code.lower()
        if len(code) != 3 or code[0] not in "rl" or code[1] not in "ud" or code[2] not in "nf":
            raise ValueError(f"configuration code {code!r}: expected arm r|l, elbow u|d, wrist n|f, e.g. 'run'")
        return cls(Arm(code[0]), Elbow(code[1]), Wrist(code[2]))

    def __str__(self) -> str:
        return self.arm.value + self.elbow.value + self.wrist.value


ALL_CONFIGS = tuple(ArmConfig(a, e, w) for a in Arm for e in Elbow for w in Wrist)


@dataclass(frozen=True)
class IKSolution:
    q: np.ndarray
    config: ArmConfig


def _sign(x: float) -> float:
    return -1.0 if x < 0.0 else 1.0


def _wrap(angle):
    angle = np.remainder(np.asarray(angle) + np.pi, 2.0 * np.pi) - np.pi
    return np.where(angle <= -np.pi, np.pi, angle)


def is_puma_type(model: Model) -> bool:
    """Whether the closed form applies (see the module docstring for the structure)."""
    dh = model.dh
    if dh is None or model.nq != 6 or np.any(model.joint_types != REVOLUTE):
        return False
    if np.any(model.parent != np.arange(6) - 1) or not np.allclose(model.axis, [0.0, 0.0, 1.0], atol=_EXACT):
        return False
    right_angles = np.abs(np.abs(np.sin(dh.alpha[[0, 2, 3, 4]])) - 1.0) < _EXACT
    return bool(np.all(right_angles) and abs(np.sin(dh.alpha[1])) < _EXACT and np.cos(dh.alpha[1]) > 0
                and np.all(np.abs([dh.a[3], dh.a[4], dh.d[4]]) < _EXACT)
                and abs(dh.a[1]) > _EXACT and math.hypot(dh.a[2], dh.d[3]) > _EXACT)


def _require(model: Model) -> None:
    if not is_puma_type(model):
        raise KinematicsError(
            f"{model.name}: closed-form IK needs a PUMA-type 6R D-H arm (|sin α1|=|sin α3..5|=1, "
            "α2=0, a4=a5=d5=0); use ik(..., method='numeric')")


def _dh_frame(alpha: float, a: float, d: float, theta: float) -> np.ndarray:
    """ⁱ⁻¹Aᵢ of eq. (1)."""
    A = np.eye(4)
    A[:3, :3] = rot_z(theta) @ rot_x(alpha)
    A[:3, 3] = a * math.cos(theta), a * math.sin(theta), d
    return A


def _base(model: Model) -> np.ndarray:
    """D-H frame 0 in the base (the first tree placement, the identity for D-H tables)."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = model.R_tree[0], model.p_tree[0]
    return T


def _arm_geometry(model: Model):
    dh = model.dh
    d_off = dh.d[1] + dh.d[2]  # shoulder offset along z₁
    e = math.sin(dh.alpha[2]) * dh.d[3]
    return d_off, e


def _arm_sign(model: Model, theta1: float, p_wrist) -> float:
    """+1 for a right arm: sin α₁ · sgn(d₂+d₃) · (p · x₁) ≥ 0 (see the module docstring)."""
    d_off, _ = _arm_geometry(model)
    ahead = p_wrist[0] * math.cos(theta1) + p_wrist[1] * math.sin(theta1)
    return _sign(math.sin(model.dh.alpha[0]) * _sign(d_off) * ahead)


def _elbow_sign(model: Model, arm_sign: float, theta3: float) -> float:
    """+1 for elbow up: (L × e) · m ≥ 0, L shoulder→wrist, e shoulder→elbow, m the arm's right."""
    d_off, e = _arm_geometry(model)
    a2, a3 = model.dh.a[1], model.dh.a[2]
    u_y = a3 * math.sin(theta3) - e * math.cos(theta3)
    return _sign(arm_sign * _sign(d_off) * (-a2 * u_y))


def configuration(model: Model, q) -> ArmConfig:
    """The arm/elbow/wrist branch that joint angles ``q`` of a PUMA-type arm are on."""
    _require(model)
    dh = model.dh
    theta = checks.vector(q, model.nq, "q") + dh.theta0
    T = _base(model)
    for i in range(4):
        T = T @ _dh_frame(dh.alpha[i], dh.a[i], dh.d[i], theta[i])
    p_wrist = np.linalg.solve(_base(model), T[:, 3])[:3]
    arm = _arm_sign(model, theta[0], p_wrist)
    elbow = _elbow_sign(model, arm, theta[2])
    return ArmConfig(Arm.RIGHT if arm > 0 else Arm.LEFT, Elbow.UP if elbow > 0 else Elbow.DOWN,
                     Wrist.NOFLIP if math.sin(theta[4]) >= 0.0 else Wrist.FLIP)


def _clamped(ratio: float, what: str, model: Model) -> float:
    if abs(ratio) > 1.0 + _REACH:
        raise KinematicsError(f"{model.name}: pose out of reach ({what})")
    return max(-1.0, min(1.0, ratio))


def _wrist_solutions(model: Model, W: np.ndarray, theta4_singular: float):
    """(θ₄, θ₅, q₆, wrist) for W = Rot(z,θ₄) Rot(x,α₄) Rot(z,θ₅) Rot(x,α₅) Rot(z,q₆)."""
    al4, al5 = model.dh.alpha[3], model.dh.alpha[4]
    s4, s5 = math.sin(al4), math.sin(al5)
    wx, wy, wz = W[:, 2]
    h = math.hypot(wx, wy)
    c5 = -s4 * s5 * wz
    out = []
    for wrist, sigma in ((Wrist.NOFLIP, 1.0), (Wrist.FLIP, -1.0)):
        if h < _EXACT:  # wrist singularity: θ₄ free, flip turns it by π
            theta4 = theta4_singular + (0.0 if sigma > 0 else math.pi)
            theta5 = math.atan2(0.0, c5)
        else:
            theta4 = math.atan2(sigma * s5 * wy, sigma * s5 * wx)
            theta5 = math.atan2(sigma * h, c5)
        rest = (rot_z(theta4) @ rot_x(al4) @ rot_z(theta5) @ rot_x(al5)).T @ W
        out.append((theta4, theta5, math.atan2(rest[1, 0], rest[0, 0]), wrist))
    return out


def solutions(model: Model, pose, q_seed=None) -> list[IKSolution]:
    """All closed-form solutions (up to 8) for a tool pose, angles wrapped to (−π, π]."""
    _require(model)
    dh = model.dh
    al, a, d, th0 = dh.alpha, dh.a, dh.d, dh.theta0
    # Body 6 (D-H frame 5 turned by q₆) in D-H frame 0: undo tool and flange (eq. 19).
    body6 = np.linalg.solve(_base(model), pose) @ np.linalg.inv(model.flange @ model.tool)
    p = body6[:3, 3]
    d_off, e = _arm_geometry(model)
    r = math.hypot(p[0], p[1])
    D = math.sin(al[0]) * d_off
    if r < _EXACT:
        raise KinematicsError(f"{model.name}: wrist centre on the waist axis (shoulder singularity: q1 undetermined)")
    beta = math.asin(_clamped(D / r, "wrist centre inside the shoulder-offset cylinder", model))
    phi = math.atan2(p[1], p[0])
    rho, psi = math.hypot(a[2], e), math.atan2(e, a[2])
    theta4_singular = (q_seed[3] if q_seed is not None else 0.0) + th0[3]

    out = []
    for theta1 in (phi + beta, phi + math.pi - beta):
        A1 = _dh_frame(al[0], a[0], d[0], theta1)
        p1 = np.linalg.solve(A1, np.append(p, 1.0))[:3]
        u2 = p1[0] ** 2 + p1[1] ** 2
        K = (u2 - a[1] ** 2 - a[2] ** 2 - d[3] ** 2) / (2.0 * a[1])
        try:
            gamma = math.acos(_clamped(K / rho, "wrist centre beyond the arm's reach", model))
        except KinematicsError:
            continue
        arm = _arm_sign(model, theta1, p)
        for theta3 in (psi + gamma, psi - gamma):
            ux = a[1] + a[2] * math.cos(theta3) + e * math.sin(theta3)
            uy = a[2] * math.sin(theta3) - e * math.cos(theta3)
            theta2 = math.atan2(p1[1], p1[0]) - math.atan2(uy, ux)
            T3 = A1 @ _dh_frame(al[1], a[1], d[1], theta2) @ _dh_frame(al[2], a[2], d[2], theta3)
            W = T3[:3, :3].T @ body6[:3, :3]
            elbow = _elbow_sign(model, arm, theta3)
            for theta4, theta5, q6, wrist in _wrist_solutions(model, W, theta4_singular):
                q = np.array([theta1, theta2, theta3, theta4, theta5, 0.0]) - th0
                q[5] = q6
                config = ArmConfig(Arm.RIGHT if arm > 0 else Arm.LEFT,
                                   Elbow.UP if elbow > 0 else Elbow.DOWN, wrist)
                out.append(IKSolution(_wrap(q), config))
    if not out:
        raise KinematicsError(f"{model.name}: pose out of reach (wrist centre at {np.round(p, 4).tolist()} m "
                              "is beyond the arm's reach)")
    return sorted(out, key=lambda s: ALL_CONFIGS.index(s.config))


def within_limits(model: Model, sols: list[IKSolution], q_seed=None) -> list[IKSolution]:
    """The solutions that fit the joint limits, each angle moved by k·2π into them (nearest
    the seed, or to 0, when several fit)."""
    ref = np.zeros(6) if q_seed is None else np.asarray(q_seed, dtype=float)
    kept = []
    for sol in sols:
        # Candidates q + 2πk for k ∈ {−2…2} (limits up to ±2 turns).
        cand = sol.q[None, :] + 2.0 * np.pi * np.arange(-2, 3)[:, None]
        ok = (cand >= model.q_min - 1e-12) & (cand <= model.q_max + 1e-12)
        if not np.all(ok.any(axis=0)):
            continue
        cost = np.where(ok, np.abs(cand - ref), np.inf)
        q = cand[np.argmin(cost, axis=0), np.arange(6)]
        kept.append(IKSolution(np.clip(q, model.q_min, model.q_max), sol.config))
    return kept


def select(model: Model, sols: list[IKSolution], q_seed=None, config=None, near_seed: bool = False) -> np.ndarray:
    """One solution: the one on ``config`` (ArmConfig or a code like "run"), else the one
    nearest ``q_seed``, else the first. ``near_seed`` first moves each angle by k·2π to the
    value nearest the seed (for solutions not already fitted into the joint limits)."""
    if not sols:
        raise KinematicsError(f"{model.name}: the pose is reachable only outside the joint limits")
    if config is not None:
        config = ArmConfig.parse(config) if isinstance(config, str) else config
        sols = [s for s in sols if s.config == config]
        if not sols:
            raise KinematicsError(f"{model.name}: no solution on configuration {config} within the joint limits")
    if q_seed is None:
        return sols[0].q.copy()
    seed = np.asarray(q_seed, dtype=float)
    candidates = [seed + _wrap(s.q - seed) if near_seed else s.q for s in sols]
    return candidates[int(np.argmin([np.sum(np.abs(q - seed)) for q in candidates]))].copy()
