"""Regression tests of issue 25's device defects (one per defect, named after it): what a device
sends is validated before use, and every fault names its device and the cause. Scenarios that
could crash the interpreter run in a child process (in_child.py)."""
from __future__ import annotations

import in_child


def test_a_wild_shm_slot_index_or_header_in_the_framegrabbers_memory_is_the_cameras_error_not_a_segfault():
    """Defect 1: 2^40 written into the published-slot word (or random bytes over the header)
    was used as an index by the compiled claim: SIGSEGV, exit 139, no controlled stop."""
    out = in_child.run("device_scenarios:framegrabber_garbage")
    assert out["valid"] == {"status": 0, "frame": True, "reason": None}
    bad = out["slot 2^40"]
    assert bad["status"] == 1 and not bad["frame"]
    assert bad["reason"].startswith("device camera failed: ") and "published slot index 1099511627776" in bad["reason"]
    assert out["published again"] == {"status": 0, "frame": True, "reason": None}  # the next tick's frame is taken
    bad = out["random header"]
    assert bad["status"] == 1 and not bad["frame"] and bad["reason"].startswith("device camera failed: ")
    assert "layout word 0 changed" in bad["reason"]  # the magic, first of the words checked
