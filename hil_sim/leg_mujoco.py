"""The prosthetic leg on contact physics: the same interface as :class:`hil_sim.leg_plant.LegPlant`,
MuJoCo underneath (``[sim] engine = "mujoco"`` with ``[sim.leg]``; docs/mujoco.md).

* **The body**: a pelvis of ``body_mass`` on a vertical slide, the thigh on the hip, the shank on
  the knee, the foot on the ankle (a planar chain, angles as the leg board reports them: hip
  flexion, knee flexion, ankle plantarflexion). The foot touches the ground with two spheres,
  heel and toe, on a frictionless plane: the stance foot slides as the hip swings the leg back
  (the pelvis does not travel forward — a treadmill whose belt offers no drag).
* **The wearer**: the hip is a stiff position servo (20 kN·m/rad) on the scripted plant's pattern
  φ̄ + A cos 2πp. The pelvis is pushed up with w(p) M g + k (h(p) − z) − c ż: w(p) the share of the
  body the sound leg carries (all of it while the prosthesis swings, none in the prosthesis's
  single stance, ramps in double support), h(p) the hip-height pattern (the scripted plant's knots,
  the stance ones raised to where a straight leg puts the hip) and k = M g/``contact_depth``. What
  the wearer does not carry, the prosthesis must: its loads are the ground's answer, not a script.
* **Knee and ankle** follow the actuator codes: hold = a stiff servo at the angle where the hold
  began; increase/decrease = the same servo on a set point moving at the set rate; release = a
  spring-damper to the rest angle (the knee: a light spring with a swing damper; the ankle: the
  foot's keel). Joint ranges are stiff stops (the knee's at 0° keeps a loaded, released knee
  straight while the ground's force passes in front of it).
* **Sensors**: the three angles and the normal contact force on the heel and the toe (MuJoCo
  touch sensors), over the weight of the whole body, with the same white noise as the scripted
  plant.

Per step: a few scalar writes into MuJoCo's arrays and one ``mj_step`` call of ``substeps``
steps; ``q``, ``qd`` and the sensor values are views of MuJoCo's state (no allocation).
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from drivers.protocols.leg_board import DECREASE, INCREASE, RELEASE
from hil_sim.leg_plant import D, LegParams, LegPlant
from hil_sim.mujoco_plant import import_mujoco

G = 9.81
FOOT_RADIUS = 0.01  # m, the heel and toe spheres
SCRIPTED_ONLY = ("knee_spring_time", "knee_load_rate", "knee_push_rate", "ankle_spring_rate", "ankle_slip_rate")


@dataclass(frozen=True)
class MujocoLegParams(LegParams):
    """``[sim.leg]`` on MuJoCo: the scripted plant's geometry, gait pattern, rates and noise, plus the
    masses, the servos and the sound leg's share. The scripted plant's stand-ins for contact
    physics (:data:`SCRIPTED_ONLY`) are refused: here the physics does what they described."""

    # changed from the scripted plant (docs/mujoco.md says why)
    hip_height: tuple = (0.84, 0.86, 0.92, 0.87, 0.82, 0.95, 0.96, 0.93, 0.86)  # m
    knee_flex_rate: float = 140.0
    knee_rest: float = 20.0
    ankle_rest: float = 12.0
    body_mass: float = 70.0  # kg, pelvis and trunk
    thigh_mass: float = 7.0
    shank_mass: float = 2.5
    foot_mass: float = 1.0
    hip_stiffness: float = 20000.0  # N·m/rad, the wearer's hip servo
    hip_damping: float = 260.0
    lock_stiffness: float = 3000.0  # N·m/rad, hold and the driven moves
    lock_damping: float = 30.0
    knee_release_stiffness: float = 60.0  # N·m/rad, the released knee's return spring
    knee_release_damping: float = 8.0  # N·m·s/rad, its swing damper
    ankle_release_stiffness: float = 400.0  # N·m/rad, the released ankle: the foot's keel
    ankle_release_damping: float = 5.0
    pelvis_damping_ratio: float = 0.7
    support_phase: tuple = (0.00, 0.10, 0.45, 0.62, 0.94)
    support: tuple = (0.6, 0.0, 0.0, 1.0, 1.0)  # the sound leg's share of the body
    substeps: int = 2  # MuJoCo steps per period

    @classmethod
    def from_table(cls, t) -> "MujocoLegParams":
        for name in SCRIPTED_ONLY:
            if t.has(name):
                raise t.error(name, "no such option on the MuJoCo leg (the contact physics replaces it)")
        p = super().from_table(t)
        phases = np.asarray(p.support_phase)
        if np.any(np.diff(phases) <= 0) or phases[0] < 0 or phases[-1] >= 1:
            raise t.error("support_phase", "increasing phases in [0, 1)")
        if not all(0.0 <= s <= 1.0 for s in p.support):
            raise t.error("support", "shares of the body weight in [0, 1]")
        if p.substeps < 1:
            raise t.error("substeps", "at least 1 MuJoCo step per period")
        for name in ("body_mass", "thigh_mass", "shank_mass", "foot_mass"):
            if getattr(p, name) <= 0:
                raise t.error(name, "a positive mass (kg)")
        return p


def _rod(name: str, length: float, mass: float) -> str:
    """A segment hanging down from its joint, its mass at mid-length (a slender rod's inertia)."""
    i = mass * length ** 2 / 12.0
    return (f'<inertial pos="0 0 {-length / 2!r}" mass="{mass!r}" diaginertia="{i!r} {i!r} {i / 100!r}"/>'
            f'<geom name="{name}" type="capsule" fromto="0 0 0 0 0 {-length!r}" size="0.03" contype="0" '
            f'conaffinity="0"/>')


def leg_mjcf(p: MujocoLegParams, timestep: float) -> str:
    """MJCF of the planar leg: x forward, z up, the joints about y (hip flexion about −y so that each
    angle is positive the way the board reports it)."""
    r = FOOT_RADIUS
    # a joint stop stiffer than MuJoCo's default (time constant 20 ms): 4 steps
    deg = lambda rng: f'range="{rng[0] * D!r} {rng[1] * D!r}" solreflimit="{4 * timestep!r} 1"'  # noqa: E731
    foot_i = p.foot_mass * (p.heel + p.toe) ** 2 / 12.0
    return f"""<mujoco model="leg">
  <compiler angle="radian"/>
  <option timestep="{timestep!r}" gravity="0 0 {-G!r}" integrator="implicitfast"/>
  <worldbody>
    <geom name="ground" type="plane" size="5 5 0.1" condim="1"/>
    <body name="pelvis">
      <joint name="pelvis_z" type="slide" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="{p.body_mass!r}" diaginertia="1 1 1"/>
      <body name="thigh">
        <joint name="hip" type="hinge" axis="0 -1 0"/>
        {_rod("thigh", p.thigh, p.thigh_mass)}
        <body name="shank" pos="0 0 {-p.thigh!r}">
          <joint name="knee" type="hinge" axis="0 1 0" limited="true" {deg(p.knee_range)}/>
          {_rod("shank", p.shank, p.shank_mass)}
          <body name="foot" pos="0 0 {-p.shank!r}">
            <joint name="ankle" type="hinge" axis="0 1 0" limited="true" {deg(p.ankle_range)}/>
            <inertial pos="{(p.toe - p.heel) / 2!r} 0 {-p.sole / 2!r}" mass="{p.foot_mass!r}"
                      diaginertia="{foot_i!r} {foot_i!r} {foot_i!r}"/>
            <geom name="heel" type="sphere" size="{r!r}" pos="{-p.heel!r} 0 {r - p.sole!r}" condim="1"/>
            <geom name="toe" type="sphere" size="{r!r}" pos="{p.toe!r} 0 {r - p.sole!r}" condim="1"/>
            <site name="heel" type="sphere" size="{2 * r!r}" pos="{-p.heel!r} 0 {r - p.sole!r}"/>
            <site name="toe" type="sphere" size="{2 * r!r}" pos="{p.toe!r} 0 {r - p.sole!r}"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="hip" joint="hip" kp="{p.hip_stiffness!r}" kv="{p.hip_damping!r}"/>
    <position name="knee" joint="knee" kp="1" kv="0"/>
    <position name="ankle" joint="ankle" kp="1" kv="0"/>
  </actuator>
  <sensor>
    <touch name="toe" site="toe"/>
    <touch name="heel" site="heel"/>
  </sensor>
</mujoco>
"""


class MujocoLegPlant:
    """State: ``q`` = (hip, knee, ankle) in rad, ``qd``; input ``actions`` = (knee, ankle) codes;
    output ``channels`` = (hip, knee, ankle, toe load, heel load) with noise. ``tau_cmd``/``tau_applied``
    exist for the joint-device interface and stay zero; ``pelvis`` is the pelvis height (m)."""

    def __init__(self, params: MujocoLegParams = MujocoLegParams(), period: float = 1e-3):
        if period <= 0:
            raise ValueError(f"period must be positive, got {period}")
        mujoco = import_mujoco()
        self._mujoco = mujoco
        self.p = p = params
        self.mjcf = leg_mjcf(p, period / p.substeps)
        self.mj_model = m = mujoco.MjModel.from_xml_string(self.mjcf)
        self.mj_data = d = mujoco.MjData(m)
        self.q, self.qd = d.qpos[1:4], d.qvel[1:4]  # views
        self.pelvis = d.qpos[0:1]
        self.tau_cmd, self.tau_applied = np.zeros(3), np.zeros(3)
        self.actions = np.zeros(2, dtype=np.int64)
        self.channels = np.zeros(5)
        self.loads = np.zeros(2)  # toe, heel (noise-free), body weights
        self._touch = d.sensordata[0:2]
        self._noise = np.zeros(5)
        self._noise_scale = np.array([p.angle_noise * D] * 3 + [p.load_noise] * 2)
        self.rng = np.random.default_rng(p.seed)
        self.weight = float(mujoco.mj_getTotalmass(m)) * G
        self._pelvis_k = self.weight / p.contact_depth
        self._pelvis_c = 2.0 * p.pelvis_damping_ratio * math.sqrt(self._pelvis_k * float(m.body_mass.sum()))
        self._gain, self._bias, self._ctrl = m.actuator_gainprm, m.actuator_biasprm, d.ctrl
        self._modes = [-1, -1]  # the knee's and ankle's codes in force (−1: none yet)
        self._targets = np.zeros(2)
        self._rates = ((p.knee_extend_rate * D, p.knee_flex_rate * D), (p.ankle_rate * D, p.ankle_rate * D))
        self._rests = (p.knee_rest * D, p.ankle_rest * D)
        self._release = ((p.knee_release_stiffness, p.knee_release_damping),
                         (p.ankle_release_stiffness, p.ankle_release_damping))
        self._ranges = ((p.knee_range[0] * D, p.knee_range[1] * D), (p.ankle_range[0] * D, p.ankle_range[1] * D))
        self._knots = self._periodic(p.hip_height_phase, p.hip_height)
        self._share_knots = self._periodic(p.support_phase, p.support)
        self.time = 0.0
        self.q[:] = (self.hip_angle(0.0), p.knee_rest * D, p.ankle_rest * D)
        self.pelvis[0] = self.hip_height(0.0)
        self._ctrl[0] = self.q[0]
        self._apply(0.0)
        mujoco.mj_forward(m, d)
        self._contacts()
        self.measure()

    @staticmethod
    def _periodic(phases, values):
        """Knots of one period repeated on each side (periodic linear interpolation)."""
        ph = list(phases)
        return [x - 1.0 for x in ph] + ph + [x + 1.0 for x in ph], list(values) * 3

    # -- the wearer -------------------------------------------------------------------------
    def phase(self, t: float) -> float:
        return (t / self.p.period + self.p.start_phase) % 1.0

    def hip_angle(self, t: float) -> float:
        return (self.p.hip_mean + self.p.hip_amplitude * math.cos(2 * math.pi * self.phase(t))) * D

    def _interp(self, knots, t: float) -> float:
        phases, values = knots
        p = self.phase(t)
        k = bisect.bisect_right(phases, p)
        w = (p - phases[k - 1]) / (phases[k] - phases[k - 1])
        return values[k - 1] + w * (values[k] - values[k - 1])

    def hip_height(self, t: float) -> float:
        return self._interp(self._knots, t)

    def support(self, t: float) -> float:
        """The sound leg's share of the body weight at time ``t``."""
        return self._interp(self._share_knots, t)

    # -- the actuators ----------------------------------------------------------------------
    def _servo(self, joint: int, kp: float, kv: float, target: float) -> None:
        a = joint + 1  # actuators: hip, knee, ankle
        self._gain[a, 0] = kp
        self._bias[a, 1] = -kp
        self._bias[a, 2] = -kv
        self._ctrl[a] = target

    def _apply(self, dt: float) -> None:
        """The knee's and ankle's servos for the present codes; the sound leg's push on the pelvis."""
        p = self.p
        for j in range(2):
            code = int(self.actions[j])
            if code != self._modes[j]:  # a new code starts from where the joint is
                self._modes[j] = code
                self._targets[j] = self.q[j + 1]
            if code == RELEASE:
                self._servo(j, *self._release[j], self._rests[j])
                continue
            if code == INCREASE:
                self._targets[j] = min(self._targets[j] + self._rates[j][1] * dt, self._ranges[j][1])
            elif code == DECREASE:
                self._targets[j] = max(self._targets[j] - self._rates[j][0] * dt, self._ranges[j][0])
            self._servo(j, p.lock_stiffness, p.lock_damping, self._targets[j])
        t = self.time + dt  # the wearer's pattern at the end of the period
        self._ctrl[0] = self.hip_angle(t)
        w = self.support(t)
        d = self.mj_data
        d.qfrc_applied[0] = (w * self.weight + self._pelvis_k * (self.hip_height(t) - d.qpos[0])
                             - self._pelvis_c * d.qvel[0])

    # -- contact ----------------------------------------------------------------------------
    def _contacts(self) -> None:
        np.multiply(self._touch, 1.0 / self.weight, out=self.loads)

    measure = LegPlant.measure  # the same sensor channels: true values plus white noise

    # -- one period -------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance one period with the present actions (``substeps`` MuJoCo steps of the period the
        plant was built for; ``dt`` advances the wearer's pattern and the driven set points), then
        measure."""
        if dt <= 0:
            return
        self._apply(dt)
        self._mujoco.mj_step(self.mj_model, self.mj_data, self.p.substeps)
        self.time += dt
        self._contacts()
        self.measure()

