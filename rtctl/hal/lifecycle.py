"""The hardware lifecycle, after ros2_control's: configure → activate → read/write →
deactivate → close.

Subclasses implement the ``_on_*`` hooks (python-can's ``_internal`` style); the public
methods enforce the order, make every transition safe to call twice, and turn an exception
from ``read``/``write`` into ``Status.ERROR`` so nothing raises into the loop.
"""
from __future__ import annotations

import enum

from rtctl.errors import HardwareError


class Status(enum.IntEnum):
    OK = 0
    ERROR = 1  # the device failed this tick: the loop engages the fallback
    DEACTIVATE = 2  # the device asks to be deactivated (e.g. its own e-stop)


class Lifecycle(enum.Enum):
    UNCONFIGURED = "unconfigured"
    INACTIVE = "inactive"  # link open, states readable
    ACTIVE = "active"  # commands accepted
    CLOSED = "closed"


class Hardware:
    """Base of every device. ``name`` comes from the configuration.

    Every tick the loop calls :meth:`read` (in its READ phase) and :meth:`write` (in its WRITE
    phase); implementations provide ``_read``/``_write``. Joint devices are
    :class:`~rtctl.hal.joints.JointGroup`; any other kind (framegrabber, I/O board …) derives
    from this class directly and is reached by the controllers that name it.
    """

    def __init__(self, name: str):
        self.name = name
        self.lifecycle = Lifecycle.UNCONFIGURED
        self.last_error: str | None = None

    # -- lifecycle -------------------------------------------------------------------
    def configure(self) -> None:
        if self.lifecycle is Lifecycle.UNCONFIGURED:
            self._on_configure()
            self.lifecycle = Lifecycle.INACTIVE
        elif self.lifecycle is Lifecycle.CLOSED:
            raise HardwareError(f"{self.name}: configure() after close()")

    def activate(self) -> None:
        self.configure()
        if self.lifecycle is Lifecycle.INACTIVE:
            self._on_activate()
            self.lifecycle = Lifecycle.ACTIVE

    def deactivate(self) -> bool:
        """Stop accepting commands and leave the actuators safe (motors off). Never raises:
        False when the device could not confirm it (``last_error`` says why)."""
        if self.lifecycle is Lifecycle.ACTIVE:
            self.lifecycle = Lifecycle.INACTIVE
            try:
                self._on_deactivate()
            except Exception as e:  # a deactivation must not stop the others
                self.last_error = f"deactivate: {e}"
                return False
        return True

    def close(self) -> None:
        """Deactivate if needed and release the link. Never raises."""
        self.deactivate()
        if self.lifecycle is Lifecycle.INACTIVE:
            try:
                self._on_close()
            except Exception as e:
                self.last_error = f"close: {e}"
        self.lifecycle = Lifecycle.CLOSED

    # -- every tick -------------------------------------------------------------------
    def read(self, t: float) -> Status:
        """Update the device's inputs. Never raises: an exception becomes ``Status.ERROR``."""
        if self.lifecycle not in (Lifecycle.INACTIVE, Lifecycle.ACTIVE):
            return Status.ERROR
        try:
            return self._read(t)
        except Exception as e:
            self.last_error = f"read: {type(e).__name__}: {e}"
            return Status.ERROR

    def write(self, t: float) -> Status:
        """Send the device's outputs (ignored unless active). Never raises."""
        if self.lifecycle is not Lifecycle.ACTIVE:
            return Status.OK
        try:
            return self._write(t)
        except Exception as e:
            self.last_error = f"write: {type(e).__name__}: {e}"
            return Status.ERROR

    # -- hooks for implementations ---------------------------------------------------
    def _read(self, t: float) -> Status:
        raise NotImplementedError

    def _write(self, t: float) -> Status:
        return Status.OK

    def _on_configure(self) -> None:
        """Open the link; after this, states are readable."""

    def _on_activate(self) -> None:
        """Start accepting commands (enable the drives)."""

    def _on_deactivate(self) -> None:
        """Stop the actuators (disable the drives)."""

    def _on_close(self) -> None:
        """Release the link."""

    def safe_state(self) -> None:
        """Put the outputs in the device's own safe state (a leg board locks its joints). The
        loop calls it in every tick the safety stage is in charge, before ``write``; joint
        devices need nothing here (the stage writes their fallback command). Must not allocate."""

    def fault_cause(self) -> str:
        """Why the device reports ERROR or DEACTIVATE, as the driver saw it: its ``last_error``
        unless the driver knows better. Called only when a fault is recorded (it may allocate)."""
        return self.last_error or "the driver gave no cause"

    def diagnostics(self) -> dict:
        """Counters and facts for status and the run summary."""
        return {"lifecycle": self.lifecycle.value, "last_error": self.last_error}
