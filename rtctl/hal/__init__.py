"""Hardware abstraction layer: interfaces only (nothing here touches a wire).

Drivers (``drivers``) and simulated devices (``hil_sim``) implement these and register
themselves in the entry-point group ``rtctl.drivers``; the daemon finds them by the name in
the configuration (:func:`rtctl.hal.registry.load_driver`).
"""
from rtctl.hal.lifecycle import Hardware, Lifecycle, Status
from rtctl.hal.framegrabber import Frame, FrameGrabber, GrabberSettings
from rtctl.hal.joints import CommandMode, JointCommand, JointGroup, JointState
from rtctl.hal.registry import available_drivers, load_driver

__all__ = [
    "Hardware", "Lifecycle", "Status", "JointGroup", "JointState", "JointCommand",
    "CommandMode", "FrameGrabber", "Frame", "GrabberSettings", "load_driver", "available_drivers",
]
