"""How long ``deactivate`` waits for the drives to report SWITCH ON DISABLED: half their RPDO
deadline (``drive_timeout``), so the next device on the loop is not starved past its own drives'
deadlines (docs/cia402.md, "Faults"). Wall-clock: a stall of 0.1 s or more in the test's
process could fail it, no stall can make it pass wrongly (a delay only makes the drive later)."""
import time

import pytest

from drivers.protocols import cia402 as c
from lockstep_rig import rigs
from test_cia402_driver import Rig

DEADLINE = 1.0  # s: the drives' RPDO deadline; the disable wait is half of it
CYCLE = 0.12  # s: each SYNC cycle of the wait takes this long (a slow link)


class LateRig(Rig):
    """Drives slow to confirm *disable voltage*: they answer every SYNC, but act on no controlword
    before wall time ``confirm_from`` — behind a link where a SYNC cycle takes ``CYCLE`` s."""

    confirm_from = None

    def __init__(self, **kw):
        super().__init__(**kw)
        for d in self.drive_list:
            d.apply_controlword = lambda cw, apply=d.apply_controlword: None if self._holding() else apply(cw)

    def _holding(self) -> bool:
        return self.confirm_from is not None and time.monotonic() < self.confirm_from

    def _after_send(self):
        if self.confirm_from is not None:
            time.sleep(CYCLE)
        super()._after_send()


@pytest.fixture
def late_rig():
    yield from rigs(LateRig)


@pytest.mark.parametrize("after, confirmed", [
    (0.42, True),  # disabled in the 4th cycle (≥ 0.48 s): within 0.5 s, awaited
    (0.70, False),  # the 5th cycle (≥ 0.60 s) ends past 0.5 s still enabled: no more cycles
])
def test_deactivate_waits_half_the_rpdo_deadline_for_the_drives(late_rig, after, confirmed):
    r = late_rig(drive_timeout=DEADLINE)
    r.activate()
    r.tick()
    r.confirm_from = time.monotonic() + after * DEADLINE
    assert r.deactivate() is confirmed, r.last_error
    states = {d.state for d in r.drive_list}
    assert states == ({c.SWITCH_ON_DISABLED} if confirmed else {c.OPERATION_ENABLED})
    if not confirmed:
        assert f"within {DEADLINE / 2:g} s" in r.last_error


def test_a_silent_drive_holds_deactivate_no_longer_than_the_budget(late_rig):
    """Each cycle of the wait gets what is left of the budget, never more (a generous bound: 10 ms
    of budget, 0.5 s allowed)."""
    r = late_rig(drive_timeout=0.02)
    r.activate()
    r.tick()
    r.drive_list[1].faults.silent = True
    started = time.monotonic()
    assert r.deactivate() is False
    assert time.monotonic() - started < 0.5
