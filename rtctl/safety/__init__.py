"""The safety stage: limits, watchdog, fallback (hold / damp), e-stop, the guard hook.

Per tick, after the controllers and before ``write()``::

    verdict = safety.check(t, tick, state, statuses, command, controller_ok, controller_error)

then write the (bounded or replaced) command; on ``Verdict.DEACTIVATE`` deactivate the
devices. See :mod:`rtctl.safety.stage` for the stop semantics and
:mod:`rtctl.safety.limits` for the clamping policy.
"""
from rtctl.safety.faults import Fault, FaultKind, Guard, GuardVerdict, Verdict
from rtctl.safety.stage import SafetyStage

__all__ = ["SafetyStage", "Verdict", "Fault", "FaultKind", "Guard", "GuardVerdict"]
