"""Real-time knobs for the loop's process, each optional and each reported.

``apply_rt(settings)`` tries the requested knobs and returns one :class:`KnobReport` per
knob (applied / off / not permitted / unsupported / failed, with the reason and the fix).
With ``enforce=True`` (``--enforce-rt``) any requested knob that did not apply raises
:class:`~rtctl.errors.RealtimeError` naming it and the fix; knobs not requested are not
enforced. ``settings`` is any object with the fields of :class:`RtSettings` (the run
configuration's ``[loop.rt]`` table has them); a zero / empty / False field means "leave
it alone". Call it once, right before the loop starts: GC freeze must
come after the set-up has allocated everything, and mlockall pins what exists by then.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import dataclasses
import enum
import gc
import os
import platform
import resource

from rtctl.errors import RealtimeError

CAP_IPC_LOCK = 14
CAP_SYS_NICE = 23
PR_SET_TIMERSLACK = 29
PR_GET_TIMERSLACK = 30
MAX_TIMER_SLACK_NS = 1_000_000  # 1 ms: the kernel may wake the loop this late; more is no real-time setting
# mlockall flags: 1|2 on x86, arm, riscv…; 0x2000|0x4000 on powerpc, sparc, alpha
_MCL = 0x6000 if platform.machine().startswith(("ppc", "sparc", "alpha")) else 3

RTPRIO_FIX = (
    "add '@realtime - rtprio 95' to /etc/security/limits.conf (and the user to group realtime), "
    "or LimitRTPRIO=95 in the systemd unit, or run with CAP_SYS_NICE"
)
MEMLOCK_FIX = (
    "add '@realtime - memlock unlimited' to /etc/security/limits.conf, "
    "or LimitMEMLOCK=infinity in the systemd unit, or run with CAP_IPC_LOCK"
)


class KnobStatus(str, enum.Enum):
    APPLIED = "applied"
    OFF = "off"  # not requested
    NOT_PERMITTED = "not permitted"
    UNSUPPORTED = "unsupported"  # this OS / Python has no such call
    FAILED = "failed"  # requested value invalid here (priority range, CPU not present …)


@dataclasses.dataclass(frozen=True)
class RtSettings:
    """What to apply; each field's zero value leaves its knob alone."""

    priority: int = 0  # SCHED_FIFO priority, 1..99
    cpus: tuple[int, ...] = ()  # CPU affinity
    mlockall: bool = False  # mlockall(MCL_CURRENT | MCL_FUTURE)
    timer_slack_ns: int = 0  # prctl(PR_SET_TIMERSLACK), 1 ns … 1 ms (the kernel reads 0 as "default")
    gc_freeze: bool = False  # gc.freeze(); gc.disable()


@dataclasses.dataclass(frozen=True)
class KnobReport:
    knob: str
    status: KnobStatus
    detail: str
    fix: str = ""

    def as_dict(self) -> dict:
        return {"knob": self.knob, "status": self.status.value, "detail": self.detail, "fix": self.fix}


def has_capability(bit: int) -> bool | None:
    """Whether the process has a capability (effective set); None when unknowable."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("CapEff:"):
                    return bool(int(line.split()[1], 16) >> bit & 1)
    except OSError:
        pass
    return None


def format_rlimit(value: int) -> str:
    return "unlimited" if value == resource.RLIM_INFINITY else str(value)


def _libc():
    return ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)


def _fifo(priority: int) -> KnobReport:
    name = "sched_fifo"
    if not hasattr(os, "sched_setscheduler"):
        return KnobReport(name, KnobStatus.UNSUPPORTED, "os.sched_setscheduler is not available here")
    lo, hi = os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    if not lo <= priority <= hi:
        return KnobReport(name, KnobStatus.FAILED, f"priority {priority} outside {lo}..{hi}",
                          f"choose a priority in {lo}..{hi}")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        soft = resource.getrlimit(resource.RLIMIT_RTPRIO)[0]
        if soft != resource.RLIM_INFINITY and soft < priority and not has_capability(CAP_SYS_NICE):
            why = f"rtprio limit {format_rlimit(soft)} < {priority} and no CAP_SYS_NICE"
            return KnobReport(name, KnobStatus.NOT_PERMITTED, why, RTPRIO_FIX)
        why = "the kernel refused although rtprio allows it: the cgroup has no real-time runtime"
        return KnobReport(name, KnobStatus.NOT_PERMITTED, why,
                          "give the cgroup an RT budget (cpu.rt_runtime_us; docker --cpu-rt-runtime) "
                          "or run outside it")
    return KnobReport(name, KnobStatus.APPLIED, f"SCHED_FIFO priority {os.sched_getparam(0).sched_priority}")


def _affinity(cpus: tuple[int, ...]) -> KnobReport:
    name = "cpu_affinity"
    if not hasattr(os, "sched_setaffinity"):
        return KnobReport(name, KnobStatus.UNSUPPORTED, "os.sched_setaffinity is not available here")
    before = sorted(os.sched_getaffinity(0))
    try:
        os.sched_setaffinity(0, cpus)
    except PermissionError as e:
        return KnobReport(name, KnobStatus.NOT_PERMITTED, f"{e.strerror}; allowed CPUs {before}",
                          "widen the cpuset of the service's cgroup or pick allowed CPUs")
    except OSError as e:
        return KnobReport(name, KnobStatus.FAILED, f"CPUs {list(cpus)}: {e.strerror}; allowed {before}",
                          f"choose CPUs among {before}")
    return KnobReport(name, KnobStatus.APPLIED, f"CPUs {sorted(os.sched_getaffinity(0))}")


def _mlockall() -> KnobReport:
    name = "mlockall"
    if platform.system() != "Linux":
        return KnobReport(name, KnobStatus.UNSUPPORTED, f"mlockall is only used on Linux, not {platform.system()}")
    if _libc().mlockall(_MCL) == 0:
        return KnobReport(name, KnobStatus.APPLIED, "current and future pages locked in RAM")
    err = ctypes.get_errno()
    limit = format_rlimit(resource.getrlimit(resource.RLIMIT_MEMLOCK)[0])
    return KnobReport(name, KnobStatus.NOT_PERMITTED,
                      f"{os.strerror(err)}: memlock limit {limit} bytes, CAP_IPC_LOCK "
                      f"{'present' if has_capability(CAP_IPC_LOCK) else 'absent'}", MEMLOCK_FIX)


def timer_slack_ns() -> int | None:
    """This thread's timer slack (ns), or None off Linux."""
    if platform.system() != "Linux":
        return None
    return _libc().prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0)


def _timer_slack(ns: int) -> KnobReport:
    name = "timer_slack"
    if platform.system() != "Linux":
        return KnobReport(name, KnobStatus.UNSUPPORTED, "PR_SET_TIMERSLACK is Linux-only")
    if not 1 <= ns <= MAX_TIMER_SLACK_NS:
        return KnobReport(name, KnobStatus.FAILED, f"{ns} ns is not a slack for a control loop",
                          f"use 1 ns for the tightest wake-ups (at most {MAX_TIMER_SLACK_NS} ns)")
    if _libc().prctl(PR_SET_TIMERSLACK, ctypes.c_ulong(ns), 0, 0, 0) != 0:
        return KnobReport(name, KnobStatus.FAILED, os.strerror(ctypes.get_errno()))
    return KnobReport(name, KnobStatus.APPLIED,
                      f"{timer_slack_ns()} ns (SCHED_FIFO tasks have none: Linux ≥ 6.7 then reads 0)")


def _freeze_gc() -> KnobReport:
    gc.collect()
    gc.freeze()  # objects alive now move to the permanent generation: never scanned again
    gc.disable()
    return KnobReport("gc_freeze", KnobStatus.APPLIED,
                      f"{gc.get_freeze_count()} objects frozen, automatic collection off")


def apply_rt(settings, *, enforce: bool = False) -> list[KnobReport]:
    """Apply the requested knobs (affinity, mlockall, timer slack, SCHED_FIFO, GC freeze —
    in that order) and report every knob; raise RealtimeError if ``enforce`` and any failed."""
    s = settings
    steps = [
        ("cpu_affinity", bool(s.cpus), lambda: _affinity(tuple(s.cpus))),
        ("mlockall", s.mlockall, _mlockall),
        ("timer_slack", bool(s.timer_slack_ns), lambda: _timer_slack(s.timer_slack_ns)),
        ("sched_fifo", bool(s.priority), lambda: _fifo(s.priority)),
        ("gc_freeze", s.gc_freeze, _freeze_gc),
    ]
    reports = [apply() if wanted else KnobReport(name, KnobStatus.OFF, "not requested")
               for name, wanted, apply in steps]
    failed = [r for r in reports if r.status not in (KnobStatus.APPLIED, KnobStatus.OFF)]
    if enforce and failed:
        raise RealtimeError("; ".join(f"{r.knob}: {r.status.value}: {r.detail} — fix: {r.fix or 'n/a'}"
                                      for r in failed))
    return reports
