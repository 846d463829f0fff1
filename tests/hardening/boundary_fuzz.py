"""Fuzzing every driver's input boundary: the engine (the child-process side of
test_driver_boundaries.py; the boundaries are in boundary_*.py).

A *boundary* is what a driver reads from outside the process: shared-memory words, serial
bytes, CAN frames, an EDS. A boundary class opens a fresh device behind it for every
hypothesis example, feeds it a sequence of adversarial inputs (``steps()``, ``inject``) and
ticks it as the loop does (``tick``); after every tick :func:`check_tick` asks what the loop
relies on:

* read()/write() returned a Status (an exception would fail the example; a signal death fails
  the child, hence the test);
* ERROR or DEACTIVATE comes with a reason that names the device and a cause from its driver
  (:func:`rtctl.safety.faults.device_reason`), never "no cause";
* every joint value the device publishes is finite and within what its codec can encode
  (``bounds``); a frame a grabber hands out is newer than the last (sequence number and capture
  time), with a field its scan delivers and words of its settings' shape;
* what the boundary's own model of the protocol says about this tick (``inject`` returns an
  :class:`Expect`, computed by the test from what it sent, not read back from the driver):
  an input the protocol must refuse is the device's ERROR, a joint nothing new came for is not
  fresh, a valid new sample is published as sent.

``EXAMPLES`` of a boundary (the attacks that found the defects of issue 25) run before the
random ones. A new driver gets the same treatment by a boundary class and one entry in the
test's table.
"""
from __future__ import annotations

import importlib
import logging
import math

import numpy as np
import structlog
from hypothesis import HealthCheck, example, given, settings

from rtctl.hal import JointGroup, Status
from rtctl.hal.framegrabber import FrameGrabber
from rtctl.safety.faults import device_reason

NO_CAUSE = "the driver gave no cause"


class Expect:
    """What the protocol promises about the tick after an input: ``error`` (it must be ERROR),
    ``status`` (exactly this one), ``stale`` (rows that must not be fresh), ``fresh`` (state
    arrays → values that must be published, all rows fresh); ``why`` explains a failure."""

    def __init__(self, error: bool = False, status: Status | None = None, stale=(), fresh: dict | None = None,
                 why: str = ""):
        self.error, self.status, self.stale, self.fresh, self.why = error, status, tuple(stale), fresh, why


def check_tick(dev, status, expect: Expect, bounds: dict | None, seen: dict) -> None:
    assert status in (Status.OK, Status.ERROR, Status.DEACTIVATE), status
    name = Status(status).name
    if status != Status.OK:
        cause = dev.fault_cause()
        assert isinstance(cause, str) and cause and cause != NO_CAUSE, (name, cause)
        reason = device_reason(dev, status)
        assert reason.startswith(f"device {dev.name} ") and reason.endswith(cause), reason
    if expect.error:
        assert status == Status.ERROR, f"{expect.why}: the tick was {name}"
    if expect.status is not None:
        assert status == expect.status, f"{expect.why}: the tick was {name}, expected {expect.status.name}"
    if isinstance(dev, JointGroup):
        _check_joints(dev.state, expect, bounds)
    if isinstance(dev, FrameGrabber):
        _check_frame(dev.grab(), seen)


def _check_joints(s, expect: Expect, bounds: dict) -> None:
    for row in expect.stale:
        assert not s.fresh[row], f"{expect.why}: row {row} published as fresh"
    if expect.fresh is not None:
        assert s.fresh.all(), f"{expect.why}: not published as fresh ({s.fresh})"
        for name, values in expect.fresh.items():
            np.testing.assert_allclose(getattr(s, name), values, rtol=0, atol=1e-12, err_msg=expect.why)
    for name, (lo, hi) in bounds.items():
        v = getattr(s, name)
        assert np.all(np.isfinite(v)) and np.all((lo - 1e-9 <= v) & (v <= hi + 1e-9)), (name, v, lo, hi)


def _check_frame(frame, seen: dict) -> None:
    if frame is None:
        return
    from drivers.protocols.framegrabber import FIELD_NAMES, SCAN_FIELDS

    s = frame.settings
    assert frame.seq > seen.get("seq", -1), (frame.seq, seen)
    assert math.isfinite(frame.capture_time) and frame.capture_time >= seen.get("capture", -math.inf), (
        frame.capture_time, seen)
    seen["seq"], seen["capture"] = frame.seq, frame.capture_time
    assert frame.field in [FIELD_NAMES[f] for f in SCAN_FIELDS[s.scan]], (frame.field, s.scan)
    assert frame.words.shape == (s.rows, s.words_per_row)


class DeviceBoundary:
    """Subclasses: ``steps()`` (a hypothesis strategy of a list of inputs), ``open()`` (a context
    manager yielding the device, configured and active), ``inject(dev, step) -> Expect``,
    ``tick(dev, k) -> Status``, ``bounds(dev)`` (state arrays' ranges, for joint devices) and
    ``EXAMPLES`` (step lists always played)."""

    EXAMPLES: list = []

    def play(self, steps, stats: dict) -> None:
        seen: dict = {}
        with self.open() as dev:
            bounds = self.bounds(dev) if isinstance(dev, JointGroup) else None
            for k, step in enumerate(steps):
                expect = self.inject(dev, step)
                status = self.tick(dev, k)
                check_tick(dev, status, expect, bounds, seen)
                stats[Status(status).name] = stats.get(Status(status).name, 0) + 1

    def bounds(self, dev) -> dict:
        raise NotImplementedError


def campaign(boundary: str, examples: int) -> dict:
    """Fuzz ``boundary`` ("module:Class") for its ``EXAMPLES`` and ``examples`` random hypothesis
    examples; the outcomes seen (an example that breaks a promise raises, with hypothesis's
    report of the smallest input that does)."""
    module, cls = boundary.split(":")
    harness = getattr(importlib.import_module(module), cls)()
    stats: dict = {}
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.CRITICAL))  # the drivers' events
    logging.getLogger("canopen").setLevel(logging.CRITICAL)  # its complaints about a mutated EDS

    def fuzz(steps):
        harness.play(steps, stats)

    for steps in harness.EXAMPLES:
        fuzz = example(steps)(fuzz)
    fuzz = settings(max_examples=examples, deadline=None, database=None,
                    suppress_health_check=list(HealthCheck))(given(harness.steps())(fuzz))
    fuzz()
    return stats
