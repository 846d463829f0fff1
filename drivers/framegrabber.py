"""The framegrabber driver (entry point ``framegrabber``): the interface's frames in the loop.

Backends, chosen by the device's ``backend`` option:

* ``"shm"`` (default): the interface's memory as POSIX shared memory
  (``multiprocessing.shared_memory``) named by ``shm``, laid out and arbitrated as
  :mod:`drivers.protocols.framegrabber` says — the device (``hil-sim``'s camera, or a bridge to
  a real grabber) creates it, this driver attaches. Frames are zero-copy views of it.
* ``"v4l2"``: a capture card through Video4Linux2 (:mod:`drivers.framegrabber_v4l2`, needs
  the ``vision`` extra).

Options::

    [[devices]]
    name = "camera"
    kind = "framegrabber"
    driver = "framegrabber"
    backend = "shm"                          # or "v4l2"
    shm = "${HIL_SIM_FRAMEGRABBER:-rtctl-framegrabber}"
    [devices.settings]                       # rtctl.hal.GrabberSettings: density, window, scan, …
    transfer_mb_s = 13.0                     # the simulated card's transfer rate (hil-sim, [sim]); unused here
    [devices.scene]                          # what a simulated camera sees (hil-sim, [sim]); unused here
"""
from __future__ import annotations

import sys
from multiprocessing import shared_memory

from drivers.protocols.framegrabber import GrabberMemory
from drivers.protocols.framegrabber_host import HostFrameGrabber, HostPort, warm_up as warm_up_protocol
from rtctl.errors import HardwareError, ProtocolError
from rtctl.hal.framegrabber import GrabberSettings
from rtctl.tomltable import Table, expand_env
from rtctl.vision.pixels import warm_up as warm_up_pixels

BACKENDS = ("shm", "v4l2")
DEFAULT_SHM = "rtctl-framegrabber"


def attach_shared_memory(name: str) -> shared_memory.SharedMemory:
    """Attach to an existing segment without adopting it: before Python 3.13 an attaching
    process's resource tracker would unlink the device's segment when this process exits."""
    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name, track=False)
    from multiprocessing import resource_tracker

    shm = shared_memory.SharedMemory(name)
    resource_tracker.unregister(shm._name, "shared_memory")  # noqa: SLF001 — the documented workaround
    return shm


def settings_table(options: Table) -> Table:
    return options.table("settings", Table({}, options.file, options.key("settings")))


class ShmFrameGrabber(HostFrameGrabber):
    """Frames from a device that shares its memory with this process."""

    def __init__(self, name: str, settings: GrabberSettings, shm_name: str):
        super().__init__(name, settings)
        self.shm_name = shm_name
        self._shm: shared_memory.SharedMemory | None = None
        self.host: HostPort | None = None
        self._device_status: dict = {}  # the device's last status, kept when closing

    @classmethod
    def from_config(cls, device, context):
        o = device.options
        if o.str("backend", "shm", choices=BACKENDS) == "v4l2":
            from drivers.framegrabber_v4l2 import V4l2FrameGrabber

            return V4l2FrameGrabber.from_config(device, context)
        shm_name = str(expand_env(o, "shm", o.str("shm", DEFAULT_SHM)))
        settings = GrabberSettings.from_table(settings_table(o))
        o.raw("scene", None)  # the simulator's: what the camera sees, and its card's rate
        o.raw("transfer_mb_s", None)
        o.done()
        return cls(device.name, settings, shm_name)

    def _on_configure(self) -> None:
        try:
            self._shm = attach_shared_memory(self.shm_name)
        except FileNotFoundError:
            raise HardwareError(f"{self.name}: no framegrabber shared memory {self.shm_name!r} "
                                f"(is hil-sim, or the grabber's server, running?)") from None
        try:
            self.host = HostPort(GrabberMemory(self._shm.buf))
        except ProtocolError as e:
            self._release()
            raise HardwareError(f"{self.name}: shared memory {self.shm_name!r}: {e}") from None

    def warm_up(self) -> None:
        warm_up_protocol()
        warm_up_pixels()

    def _on_close(self) -> None:
        if self.host is not None:
            self._device_status = self.host.device_status()
            self.host.release()
        self._release()

    def _release(self) -> None:
        self.host, self._latest = None, None  # the views into the segment go first
        if self._shm is not None:
            try:
                self._shm.close()
            except BufferError:  # a frame someone kept still views it: the mapping goes with it
                pass
            self._shm = None

    def diagnostics(self) -> dict:
        device = self.host.device_status() if self.host is not None else self._device_status
        return {**super().diagnostics(), "device": device, "shm": self.shm_name}
