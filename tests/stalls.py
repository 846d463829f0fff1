"""The one exception a test raises when its own record shows that this shared machine stopped
it (an overrun, a late wake-up, a watchdog that tripped while commanded): the tests marked
``flaky(only_rerun=["VmStall"])`` retry it, and nothing else (docs/testing.md)."""


class VmStall(Exception):
    """A bound failed in a run whose own record shows that the machine stalled it."""
