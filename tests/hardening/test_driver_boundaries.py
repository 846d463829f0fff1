"""Nothing from a wire or a shared segment is trusted (issue 25): every driver's input boundary
fuzzed with random and adversarial inputs, in a child process — a segfault fails the test, not
pytest. What each campaign feeds and checks: tests/hardening/boundary_fuzz.py (the engine) and
boundary_*.py (one class per boundary).

A new driver gets this test by one entry in BOUNDARIES (and its class); a driver registered
without one fails test_every_driver_has_its_input_boundary_fuzzed. RTCTL_FUZZ_EXAMPLES sets the
random examples per boundary (2000 for a deep run; default: each entry's own count)."""
from __future__ import annotations

import os
from importlib.metadata import entry_points

import pytest

import in_child

EXAMPLES = os.environ.get("RTCTL_FUZZ_EXAMPLES")

# (driver, its boundary) → (class, random examples by default, outcomes it must reach)
BOUNDARIES = {
    ("framegrabber", "shared-memory words"): ("boundary_framegrabber:FramegrabberWords", 150, {"OK", "ERROR"}),
    ("leg_board", "serial bytes"): ("boundary_leg_board:LegBoardBytes", 100, {"OK", "ERROR"}),
    ("mit_can", "CAN frames"): ("boundary_can:MitFrames", 150, {"OK", "ERROR"}),
    ("cia402", "CAN frames (TPDO, EMCY, heartbeat, SDO, NMT)"): ("boundary_can:Cia402Frames", 60, {"OK", "ERROR"}),
    ("cia402", "EDS and PDO mapping"): ("boundary_eds:EdsContents", 100, {"accepted", "refused"}),
}


@pytest.mark.parametrize("boundary", BOUNDARIES, ids=[f"{d}: {b}" for d, b in BOUNDARIES])
def test_a_drivers_input_boundary_never_crashes_and_every_bad_input_is_its_error(boundary):
    harness, examples, outcomes = BOUNDARIES[boundary]
    examples = int(EXAMPLES) if EXAMPLES else examples
    seen = in_child.run("boundary_fuzz:campaign", harness, examples, timeout=300 + examples)
    assert outcomes <= set(seen), seen  # both sides of the boundary were reached, not only one


def test_every_driver_has_its_input_boundary_fuzzed():
    """Every driver of real hardware registered with rtctl (not hil_sim's simulated devices)."""
    drivers = {ep.name for ep in entry_points(group="rtctl.drivers") if ep.module.startswith("drivers.")}
    assert drivers and drivers <= {driver for driver, _ in BOUNDARIES}, drivers
