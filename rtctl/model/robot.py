"""Robot description: a serial chain of 1-DoF joints (Pinocchio's *model*).

The model is immutable and numeric; workspaces for the algorithms live elsewhere
(Pinocchio's model/data split). Conventions, shared by every algorithm:

* body ``i`` is the frame in which joint ``i`` moves: its placement in body ``parent[i]``
  is ``T_tree[i] @ T_joint(q_i)`` where ``T_tree[i] = (R_tree[i], p_tree[i])`` is constant and
  ``T_joint`` is a rotation about ``axis[i]`` (revolute) or a translation along it (prismatic);
* for a D-H robot (Paul's convention, eq. 1 of docs/kinematics.md) body ``i`` is D-H frame
  ``i-1`` rotated by ``q_i`` about its z axis, so ``axis = z`` and ``T_tree[i]`` is the fixed
  part ``Rot(z, θ0) Trans(0,0,d) Trans(a,0,0) Rot(x, α)`` of the previous link;
* ``flange`` places the end frame (D-H frame n, or a URDF's last link) in the last body and
  ``tool`` the tool frame in the flange (eq. 6-7): tool pose = ⁰T_n(q) · flange · tool;
* ``params[i]`` are link ``i``'s 10 inertial parameters in body ``i`` coordinates, in
  Pinocchio's order (m, m·c_x, m·c_y, m·c_z, J_xx, J_xy, J_yy, J_xz, J_yz, J_zz), J the
  rotational inertia about the body origin;
* ``gravity`` is the gravity acceleration in base coordinates (default (0, 0, −9.81)).

Motor data (armature, friction, gear ratio) is carried for the simulator's plant and
for controllers that want it; the rigid-body algorithms ignore it, as Pinocchio's do.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from rtctl.errors import ModelError

REVOLUTE = 0
PRISMATIC = 1
MAX_JOINTS = 64  # the robot size rtctl supports: robot files and run configurations refuse more


@dataclass(frozen=True)
class DHTable:
    """Paul's standard D-H parameters, kept for closed-form inverse kinematics.

    ``theta0`` is the joint-angle offset (θ = q + θ0 for revolute joints) and ``d`` the
    link offset (d = q + d for prismatic joints); lengths in metres, angles in radians.
    """

    alpha: np.ndarray
    a: np.ndarray
    d: np.ndarray
    theta0: np.ndarray


COULOMB_VELOCITY = 0.01  # v_c (rad/s, m/s): Coulomb friction acts as coulomb·tanh(q̇ / v_c), in the plant and the feed-forward


@dataclass(frozen=True)
class Motors:
    """Per-joint drive-train data, referred to the joint side (N·m, N·m·s/rad, kg·m²); Coulomb
    friction is smoothed as coulomb·tanh(q̇ / ``COULOMB_VELOCITY``)."""

    armature: np.ndarray  # reflected rotor inertia G²·J_m
    viscous: np.ndarray  # viscous friction coefficient
    coulomb: np.ndarray  # Coulomb friction torque magnitude
    gear_ratio: np.ndarray


@dataclass(frozen=True, eq=False)
class Model:
    name: str
    joint_names: tuple[str, ...]
    joint_types: np.ndarray  # (n,) int64, REVOLUTE or PRISMATIC
    parent: np.ndarray  # (n,) int64, -1 for the base
    axis: np.ndarray  # (n, 3) unit joint axis in body i coordinates
    R_tree: np.ndarray  # (n, 3, 3) orientation of joint frame i in body parent[i]
    p_tree: np.ndarray  # (n, 3) origin of joint frame i in body parent[i]
    params: np.ndarray  # (n, 10) inertial parameters, Pinocchio's order
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    q_min: np.ndarray | None = None  # (n,) joint limits; ±inf when unlimited
    q_max: np.ndarray | None = None
    v_max: np.ndarray | None = None  # (n,) velocity limits
    tau_max: np.ndarray | None = None  # (n,) effort limits
    flange: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    dh: DHTable | None = None
    motors: Motors | None = None
    reconstructed: str | None = None  # why a description is a reconstruction, if it is

    def __post_init__(self):
        n = len(self.joint_names)
        shapes = {
            "joint_types": (n,), "parent": (n,), "axis": (n, 3), "R_tree": (n, 3, 3),
            "p_tree": (n, 3), "params": (n, 10), "gravity": (3,), "flange": (4, 4), "tool": (4, 4),
        }
        for name, shape in shapes.items():
            if np.shape(getattr(self, name)) != shape:
                raise ModelError(f"{self.name}: {name} has shape {np.shape(getattr(self, name))}, expected {shape}")
        inf = np.full(n, np.inf)
        defaults = {"q_min": -inf, "q_max": inf, "v_max": inf, "tau_max": inf}
        for name, default in defaults.items():
            value = getattr(self, name)
            object.__setattr__(self, name, default.copy() if value is None else np.asarray(value, float))
        if np.any(self.parent >= np.arange(n)):
            raise ModelError(f"{self.name}: parents must precede their children")
        for name in ("axis", "R_tree", "p_tree", "params", "gravity", "flange", "tool"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise ModelError(f"{self.name}: {name} has non-finite values (a number too large?)")
        for name in ("joint_types", "parent", "axis", "R_tree", "p_tree", "params", "gravity",
                     "q_min", "q_max", "v_max", "tau_max", "flange", "tool"):
            getattr(self, name).setflags(write=False)

    @property
    def nq(self) -> int:
        return len(self.joint_names)

    @property
    def nv(self) -> int:
        return self.nq

    def with_params(self, params) -> "Model":
        """The same robot with other inertial parameters (n×10, Pinocchio's order)."""
        params = np.array(params, dtype=float).reshape(self.nq, 10)
        return replace(self, params=params)

    def with_tool(self, tool) -> "Model":
        """The same robot with another tool frame (4×4 homogeneous, in the flange)."""
        return replace(self, tool=np.array(tool, dtype=float))

    def to_urdf(self) -> str:
        """The model as URDF text, so any robot opens in other tools (and in Pinocchio)."""
        from rtctl.model.urdf import to_urdf

        return to_urdf(self)
