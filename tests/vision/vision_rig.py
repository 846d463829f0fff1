"""A camera simulator and the host end of its buffer, in this process, for the vision tests."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from drivers.protocols.framegrabber import CLOCK_LOOP, DevicePort, GrabberMemory, buffer_bytes
from drivers.protocols.framegrabber_host import HostPort
from hil_sim.camera import CameraSim
from hil_sim.render import Scene
from rtctl.config import load_config
from rtctl.hal.framegrabber import Frame, FrameGrabber, GrabberSettings
from rtctl.model import load_robot
from rtctl.vision.camera import Camera
from rtctl.vision.pixels import unpack
from runtime_helpers import PUMA

READY = np.radians([0, 45, -180, 0, 45, 0])
CAMERA = Camera.looking_at((1.7, -1.2, 0.9), (0.35, 0.05, 0.0), 760.0)
VISION_CONFIG = Path(__file__).parents[2] / "configs/puma560_vision_sim.toml"


def observer_config(tmp_path, extra: str = ""):
    """The vision configuration with ``extra`` lines in its marker observer's options:
    (the loaded configuration, the observer's controller section)."""
    text = VISION_CONFIG.read_text().replace("search_px = 32.0", "search_px = 32.0\n" + extra)
    text = text.replace('"robots/puma560.toml"', f'"{VISION_CONFIG.parent / "robots/puma560.toml"}"')
    path = tmp_path / "vision.toml"
    path.write_text(text)
    cfg = load_config(path)
    return cfg, next(c for c in cfg.controllers if c.type == "marker_observer")


def programmed_pair(settings):
    """A fresh in-process buffer, a host that has programmed ``settings`` and the device's end:
    (memory, host, device, register generation, register words as the device reads them)."""
    memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True)
    host = HostPort(memory)
    host.program(settings)
    dev = DevicePort(memory)
    gen, regs = dev.registers()
    return memory, host, dev, gen, regs


class Rig:
    """The PUMA 560 (or ``model``) at ``q`` (a callable of time, or fixed) filmed in lock-step."""

    def __init__(self, settings, q=READY, model=None, ticks_per_field: int = 20, scene: Scene | None = None,
                 transfer_mb_s: float = 13.0):
        self.model = model if model is not None else load_robot(PUMA)
        self.memory = GrabberMemory(np.zeros(buffer_bytes(), dtype=np.uint8), create=True, clock=CLOCK_LOOP)
        self.host = HostPort(self.memory)
        self.host.program(settings)
        self.t = 0.0
        self.q = q if callable(q) else (lambda t: q)
        self.period = 0.020 / ticks_per_field
        self.camera = CameraSim(scene or Scene(CAMERA), self.model, self.memory, lambda: self.q(self.t),
                                ticks_per_field=ticks_per_field, transfer_mb_s=transfer_mb_s)
        self.tick = 0

    def frames(self, seconds: float):
        """(arrival time, frame copy) of every image taken while running ``seconds`` of ticks."""
        out = []
        for _ in range(round(seconds / self.period)):
            self.t = self.tick * self.period
            self.camera.step(round(self.t * 1e9))
            frame = self.host.take(self.t, 0)
            if frame is not None:
                out.append((self.t, frame.copy()))
            self.tick += 1
        return out


class NoImages:
    """A framegrabber that never has an image (the observer's own ticks only)."""

    def grab(self):
        return None


def observer_after(model, qs, t0=0.0, dt=0.001, **options):
    """A marker observer, reset at READY, that saw joint positions ``qs`` at ticks ``t0``,
    ``t0 + dt`` … and no image."""
    from rtctl.control.base import Reference
    from rtctl.hal.joints import JointCommand, JointState
    from rtctl.vision.observer import MarkerObserver

    observer = MarkerObserver("marker", model, CAMERA, **options)
    observer.grabber = NoImages()
    state, ref, command = JointState(model.nq), Reference(model.nq), JointCommand(model.nq)
    state.position[:] = READY
    observer.reset(state)
    for k, q in enumerate(qs):
        state.position[:] = q
        observer.update(t0 + dt * k, state, ref, command)
    return observer


def predicted_at(observer, model, capture_time):
    """The observer's predicted pixel for a blank image captured at ``capture_time``."""
    settings = GrabberSettings(density=64, scan="frame", word_bits=8)
    observer.observe(Frame(1, capture_time, "frame", settings,
                           np.zeros((settings.rows, settings.words_per_row), dtype=np.uint8), unpack))
    return observer.internals["marker_predicted_px"]


class NthPoll(FrameGrabber):
    """A framegrabber whose first image (a stand-in: ``copy()`` gives "the image") arrives at
    poll ``n``; ``times`` records each poll's time."""

    def __init__(self, n):
        super().__init__("cam", GrabberSettings(density=64, scan="frame", word_bits=8))
        self.n, self.times = n, []

    def _send(self, settings, t):
        pass

    def _poll(self, t):
        from types import SimpleNamespace

        self.times.append(t)
        self._latest = SimpleNamespace(copy=lambda: "the image")
        return len(self.times) == self.n
