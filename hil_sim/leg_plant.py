"""The prosthetic leg as a plant: a kinematic thigh–shank–foot in the sagittal plane.

* **Hip** (the wearer's, not actuated): a normal walking pattern, φ(p) = φ̄ + A cos 2πp over
  the gait phase p = t / T (flexion positive, thigh forward; most flexed at p = 0).
* **Hip height** above the ground: a periodic pattern of the pelvis (lowest in double support,
  highest while the sound leg carries the body), linear between knots.
* **Knee** κ (flexion positive, 0 = straight) and **ankle** α (plantarflexion positive) are
  the cybernetic actuators: hold keeps the angle, increase/decrease move it at a set rate,
  release frees it — a released knee returns to its rest angle with a spring (time constant),
  is pushed straight while the heel carries load (alignment stability) and is flexed while only
  the forefoot does (push-off); a released ankle returns to its rest angle. A held ankle is a
  brake: when only the toe carries load, the ground back-drives it towards a flat foot.
* **Foot contact** from the geometry: heel and toe points (sole below the ankle, heel behind,
  toe ahead) against the ground at the hip's height; the load at each point is its
  penetration over ``contact_depth`` (1 = the full body weight: a soft sole and ground).
* **Sensors**: hip, knee and ankle angles and toe and heel loads, with white noise.

It is a gait *generator* with the leg's actuators in the loop, not a dynamics model: what the
controller changes (when the knee locks, extends or flexes, when the ankle is driven) changes
the angles and so the contacts, and a wrong action visibly breaks the walk. Units: SI inside
(rad, m, s); the options give angles in degrees.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, fields

import numpy as np

from drivers.protocols.leg_board import DECREASE, INCREASE, RELEASE

D = math.pi / 180.0
HIP, KNEE, ANKLE, TOE, HEEL = range(5)


@dataclass(frozen=True)
class LegParams:
    """Options of ``[sim.leg]`` (angles in degrees, rates in degrees per second)."""

    period: float = 1.2  # s per gait cycle
    hip_mean: float = 8.0
    hip_amplitude: float = 22.0
    thigh: float = 0.44  # m
    shank: float = 0.43
    sole: float = 0.06  # ankle above the sole
    heel: float = 0.06  # heel behind the ankle
    toe: float = 0.10  # ball of the foot ahead of the ankle
    hip_height_phase: tuple = (0.00, 0.10, 0.30, 0.50, 0.62, 0.70, 0.80, 0.90, 0.96)
    hip_height: tuple = (0.83, 0.84, 0.86, 0.80, 0.80, 0.93, 0.96, 0.93, 0.86)  # m
    contact_depth: float = 0.02  # m of penetration for the full body weight
    knee_extend_rate: float = 150.0  # decrease
    knee_flex_rate: float = 190.0  # increase
    knee_rest: float = 15.0
    knee_spring_time: float = 0.3  # s
    knee_load_rate: float = 50.0  # heel loaded, released: pushed straight
    knee_push_rate: float = 100.0  # only the forefoot loaded, released: flexed
    knee_range: tuple = (0.0, 75.0)
    ankle_rate: float = 15.0
    ankle_rest: float = 20.0
    ankle_spring_rate: float = 60.0
    ankle_slip_rate: float = 400.0  # held ankle back-driven by a loaded toe
    ankle_range: tuple = (-20.0, 40.0)
    angle_noise: float = 0.3  # degrees, standard deviation
    load_noise: float = 0.02  # body weights
    start_phase: float = 0.75  # mid-swing: the automaton's initial state 1
    seed: int = 1

    @classmethod
    def from_table(cls, t) -> "LegParams":
        """From a ``rtctl.tomltable.Table`` (every key optional)."""
        kw = {}
        for f in fields(cls):
            if not t.has(f.name):
                continue
            if isinstance(f.default, int):  # seed, and a subclass's counts
                kw[f.name] = t.int(f.name, min=0)
            elif isinstance(f.default, tuple):
                kw[f.name] = tuple(t.vector(f.name, len(f.default)).tolist())
            else:
                kw[f.name] = t.float(f.name, min=0.0 if f.name not in ("hip_mean", "start_phase") else None)
        t.done()
        p = cls(**kw)
        phases = np.asarray(p.hip_height_phase)
        if np.any(np.diff(phases) <= 0) or phases[0] < 0 or phases[-1] >= 1:
            raise t.error("hip_height_phase", "increasing phases in [0, 1)")
        if p.period <= 0 or p.contact_depth <= 0 or p.knee_spring_time <= 0:
            raise t.error("period", "positive period, contact_depth and knee_spring_time")
        return p


class LegPlant:
    """State: ``q`` = (hip, knee, ankle) in rad, ``qd``; input ``actions`` = (knee, ankle)
    codes; output ``channels`` = (hip, knee, ankle, toe load, heel load) with noise.
    ``tau_cmd``/``tau_applied`` exist for the joint-device interface and stay zero."""

    def __init__(self, params: LegParams = LegParams()):
        self.p = params
        self.q = np.zeros(3)
        self.qd = np.zeros(3)
        self.tau_cmd = np.zeros(3)
        self.tau_applied = np.zeros(3)
        self.actions = np.zeros(2, dtype=np.int64)
        self.channels = np.zeros(5)
        self.loads = np.zeros(2)  # toe, heel (noise-free)
        self._noise = np.zeros(5)
        self._noise_scale = np.array([params.angle_noise * D] * 3 + [params.load_noise] * 2)
        self.rng = np.random.default_rng(params.seed)
        # knots of the pelvis height, one period repeated on each side (periodic interpolation)
        ph, h = list(params.hip_height_phase), list(params.hip_height)
        self._phases = [x - 1.0 for x in ph] + ph + [x + 1.0 for x in ph]
        self._heights = h * 3
        self.time = 0.0
        self.q[:] = (self.hip_angle(0.0), params.knee_rest * D, params.ankle_rest * D)
        self._contacts()
        self.measure()

    # -- the wearer -------------------------------------------------------------------------
    def phase(self, t: float) -> float:
        return (t / self.p.period + self.p.start_phase) % 1.0

    def hip_angle(self, t: float) -> float:
        return (self.p.hip_mean + self.p.hip_amplitude * math.cos(2 * math.pi * self.phase(t))) * D

    def hip_height(self, t: float) -> float:
        p, phases, heights = self.phase(t), self._phases, self._heights
        k = bisect.bisect_right(phases, p)
        w = (p - phases[k - 1]) / (phases[k] - phases[k - 1])
        return heights[k - 1] + w * (heights[k] - heights[k - 1])

    # -- contact ----------------------------------------------------------------------------
    def _contacts(self) -> None:
        p = self.p
        phi, kappa, alpha = self.q
        psi = phi - kappa  # shank from the vertical, foot forward positive
        pitch = psi - alpha  # sole from the horizontal, toe up positive
        ankle = self.hip_height(self.time) - p.thigh * math.cos(phi) - p.shank * math.cos(psi)
        sole = ankle - p.sole * math.cos(pitch)
        toe = sole + p.toe * math.sin(pitch)
        heel = sole - p.heel * math.sin(pitch)
        self.loads[0] = max(0.0, -toe) / p.contact_depth
        self.loads[1] = max(0.0, -heel) / p.contact_depth

    def measure(self) -> None:
        """The sensor channels: true values plus white noise."""
        ch = self.channels
        ch[:3] = self.q
        ch[3:] = self.loads
        self.rng.standard_normal(out=self._noise)
        self._noise *= self._noise_scale
        ch += self._noise

    # -- one period -------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance by ``dt`` with the present actions, then measure."""
        if dt <= 0:
            return
        p = self.p
        toe_loaded, heel_loaded = self.loads[0] > 0.1, self.loads[1] > 0.1
        toe_touching, heel_touching = self.loads[0] > 0.05, self.loads[1] > 0.05
        knee, ankle = int(self.actions[0]), int(self.actions[1])
        kappa, alpha = self.q[1] / D, self.q[2] / D
        if knee == INCREASE:
            dk = p.knee_flex_rate
        elif knee == DECREASE:
            dk = -p.knee_extend_rate
        elif knee == RELEASE:
            if heel_loaded:
                dk = -p.knee_load_rate
            elif toe_loaded:
                dk = p.knee_push_rate
            else:
                dk = (p.knee_rest - kappa) / p.knee_spring_time
        else:
            dk = 0.0
        if ankle == INCREASE:
            da = p.ankle_rate
        elif ankle == DECREASE:
            da = -p.ankle_rate
        elif ankle == RELEASE:
            da = math.copysign(min(abs(p.ankle_rest - alpha) / dt, p.ankle_spring_rate), p.ankle_rest - alpha)
        elif toe_touching and not heel_touching:
            da = -p.ankle_slip_rate
        else:
            da = 0.0
        new_kappa = min(max(kappa + dk * dt, p.knee_range[0]), p.knee_range[1])
        new_alpha = min(max(alpha + da * dt, p.ankle_range[0]), p.ankle_range[1])
        self.time += dt
        phi = self.hip_angle(self.time)
        self.qd[0] = (phi - self.q[0]) / dt
        self.qd[1] = (new_kappa - kappa) * D / dt
        self.qd[2] = (new_alpha - alpha) * D / dt
        self.q[0], self.q[1], self.q[2] = phi, new_kappa * D, new_alpha * D
        self._contacts()
        self.measure()
