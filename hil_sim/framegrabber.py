"""The simulated framegrabber: a camera looking at the simulated robot, behind the real wire.

* ``sim_framegrabber`` (entry point; what a ``[sim]`` run puts in place of a framegrabber
  device): the camera runs *in lock-step* inside the loop's process — its fields advance with
  the loop's time, their work spread over the ticks a field spans — and the loop reads it
  through the same shared-buffer protocol the real driver uses, over an in-process buffer.
* :class:`FreeRunningCamera` (``hil-sim``): the camera in the simulator's own process, on
  CLOCK_MONOTONIC, writing into a named shared memory the ``framegrabber`` driver attaches to.

Device options (``[[devices]]`` with ``kind = "framegrabber"``): ``[devices.settings]`` (the
grabber's, :class:`rtctl.hal.GrabberSettings`), ``[devices.scene]`` (what the camera
sees, :class:`hil_sim.render.Scene`, with its ``[devices.scene.camera]``) and
``transfer_mb_s``, the simulated card's transfer rate in 10^6 bytes a second (default 13, the
paper's; :mod:`hil_sim.transfer`). The real driver's own options (``backend``, ``shm``,
``device`` …) are accepted and unused here.
"""
from __future__ import annotations

import os
import threading
import time

import numpy as np

from drivers.protocols.framegrabber import CLOCK_LOOP, CLOCK_MONOTONIC, MIN_SLOTS, GrabberMemory, buffer_bytes
from drivers.protocols.framegrabber_host import HostFrameGrabber, HostPort, warm_up as warm_up_protocol
from rtctl.hal.framegrabber import FIELD_PERIOD_S, GrabberSettings
from rtctl.tomltable import ENV_TEMPLATE, Table
from rtctl.vision.pixels import warm_up as warm_up_pixels
from hil_sim.camera import FIELD_NS, CameraSim
from hil_sim.render import Scene
from hil_sim.transfer import PAPER_MB_S

DRIVER_KEYS = ("backend", "shm", "device", "attach_timeout_s", "pixel_format", "capture_size")
# the published, the held and the claimed slot, an image in transfer and the one being scanned
SIM_SLOTS = MIN_SLOTS + 1


def read_options(options: Table) -> tuple[GrabberSettings, Scene, float]:
    """Settings, scene and transfer rate (MB/s) from a framegrabber device's table (the
    driver's own keys ignored)."""
    settings = GrabberSettings.from_table(options.table("settings", Table({}, options.file, options.key("settings"))))
    scene = Scene.from_table(options.table("scene"))
    rate = options.float("transfer_mb_s", PAPER_MB_S, positive=True)
    for key in DRIVER_KEYS:
        options.raw(key, None)
    options.done()
    return settings, scene, rate


def warm_up_camera(camera: CameraSim) -> None:
    """Compile (or load from the cache) what a camera and its host run, before the first field."""
    warm_up_protocol()
    warm_up_pixels()
    camera.renderer.freeze(camera.q_source(), 64)
    camera.renderer.draw(np.zeros((2, 64), dtype=np.float32), range(0, 2), 0, 1, 0, 64, 64)


class SimFrameGrabber(HostFrameGrabber):
    """The camera in lock-step with the loop, read through the shared-buffer protocol."""

    def __init__(self, name: str, settings: GrabberSettings, camera: CameraSim, memory: GrabberMemory):
        super().__init__(name, settings)
        self.camera, self.memory = camera, memory
        self.host = HostPort(memory)

    @classmethod
    def from_config(cls, device, context) -> "SimFrameGrabber":
        settings, scene, rate = read_options(device.options)
        hub = context.shared.get("sim_hub")
        if hub is None:
            raise device.options.error("kind", "a simulated framegrabber films the embedded simulator's robot: "
                                               "the joints must be simulated too")
        memory = GrabberMemory(np.zeros(buffer_bytes(SIM_SLOTS), dtype=np.uint8), create=True, n_slots=SIM_SLOTS,
                               clock=CLOCK_LOOP)
        plant = hub.plant
        camera = CameraSim(scene, plant.model, memory, lambda: plant.q,
                           ticks_per_field=max(1, round(FIELD_PERIOD_S / context.period)), transfer_mb_s=rate)
        return cls(device.name, settings, camera, memory)

    def warm_up(self) -> None:
        warm_up_camera(self.camera)

    def _poll(self, t: float) -> bool:
        self.camera.step(round(t * 1e9))  # the device first, in lock-step: then the host's end
        return super()._poll(t)

    def diagnostics(self) -> dict:
        c = self.camera
        return {**super().diagnostics(), "device": {"fields": c.field + 1, "images": c.port.seq,
                                                    "no_free_slot": c.port.skipped, "missed_fields": c.missed_fields,
                                                    "settings_errors": c.settings_errors}}


class FreeRunningCamera:
    """``hil-sim``'s camera: a thread that steps a :class:`CameraSim` at every field boundary
    of CLOCK_MONOTONIC, drawing a whole field at once, and when an image's transfer ends."""

    def __init__(self, scene, model, memory: GrabberMemory, q_source, transfer_mb_s: float = PAPER_MB_S):
        if memory.clock != CLOCK_MONOTONIC:
            raise ValueError("a free-running camera stamps its fields on CLOCK_MONOTONIC")
        epoch = time.monotonic_ns()
        self.camera = CameraSim(scene, model, memory, q_source, epoch_ns=epoch - epoch % FIELD_NS,
                                clock=time.monotonic_ns, transfer_mb_s=transfer_mb_s)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camera", daemon=True)

    def start(self) -> None:
        """Compile first (a cold cache took seconds: the first fields were all missed), then run."""
        warm_up_camera(self.camera)
        self._thread.start()

    def _run(self) -> None:
        c = self.camera
        while not self._stop.is_set():
            c.step(time.monotonic_ns())
            self._stop.wait(max(0.0, (c.next_event_ns() - time.monotonic_ns()) * 1e-9))

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)

    @property
    def counters(self) -> dict:
        c = self.camera
        return {"fields": c.field + 1, "images": c.port.seq, "no_free_slot": c.port.skipped,
                "missed_fields": c.missed_fields, "settings_errors": c.settings_errors}


class CameraServer:
    """One framegrabber device of a configuration, served by ``hil-sim``: the named shared
    memory (created here, removed at exit) and the free-running camera writing into it."""

    def __init__(self, device: Table, model, q_source, index: int):
        from multiprocessing import shared_memory

        self.name = device.str("name")
        settings, scene, rate = read_options(_without(device, "name", "kind", "driver"))
        value = device.data.get("shm", "rtctl-framegrabber")
        names = [m[0] for m in ENV_TEMPLATE.findall(value)] if isinstance(value, str) else []
        # a name given by a variable is made unique here and handed over (hil-sim's JSON line)
        self.shm_name = f"rtctl-fg-{os.getpid()}-{index}" if names else str(value)
        self.env = {var: self.shm_name for var in names}
        try:
            self.shm = shared_memory.SharedMemory(self.shm_name, create=True, size=buffer_bytes(SIM_SLOTS))
        except FileExistsError:
            raise device.error("shm", f"a shared memory name not in use ({self.shm_name!r} exists: another "
                                      f"hil-sim? remove /dev/shm/{self.shm_name} if it is stale)") from None
        self.memory = GrabberMemory(self.shm.buf, create=True, n_slots=SIM_SLOTS, clock=CLOCK_MONOTONIC)
        self.settings = settings  # what the host will program (announced; the registers rule)
        self.camera = FreeRunningCamera(scene, model, self.memory, q_source, rate)

    def info(self) -> dict:
        return {"shm": self.shm_name, "settings": self.settings.__dict__}

    def close(self) -> None:
        self.camera.stop()
        self.memory = self.camera = None  # views of the segment go before it is closed
        try:
            self.shm.close()
        except BufferError:
            pass
        self.shm.unlink()


def _without(t: Table, *keys: str) -> Table:
    """The device table's options: what the device-level keys leave."""
    for key in keys:
        t.raw(key, None)
    return t


def camera_servers(config: Table, plant) -> list[CameraServer]:
    """The configuration's framegrabber devices, each with its camera filming ``plant``."""
    servers = []
    for d in config.tables("devices", []):
        if d.data.get("kind") == "framegrabber":
            servers.append(CameraServer(d, plant.model, lambda: plant.q, len(servers)))
    return servers
