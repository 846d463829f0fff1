"""`rtctl doctor`: is this machine ready to run a real-time loop, and what to change.

Each ``check_*`` is a pure function of what was read (None = not readable), so every verdict
is testable without the machine; :func:`doctor` reads the live system and calls them all.
"""
from __future__ import annotations

import dataclasses
import glob
import os
import re
import resource

from rtctl.timing.rt import (
    CAP_IPC_LOCK, CAP_SYS_NICE, MEMLOCK_FIX, RTPRIO_FIX, format_rlimit, has_capability, timer_slack_ns,
)

OK, WARN, FAIL, UNKNOWN = "ok", "warn", "fail", "unknown"


@dataclasses.dataclass(frozen=True)
class Check:
    name: str
    status: str  # ok | warn | fail | unknown
    value: str
    advice: str = ""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def _unknown(name: str, path: str) -> Check:
    return Check(name, UNKNOWN, f"{path} not readable")


def check_preemption(uname_version: str, realtime: str | None, preempt_mode: str | None,
                     cmdline: str | None) -> Check:
    """PREEMPT_RT is the goal; a PREEMPT_DYNAMIC kernel is only as good as its current mode
    (``/sys/kernel/debug/sched/preempt`` shows it in parentheses, or ``preempt=`` on the command line)."""
    name, rt_advice = "preemption", "for bounded latency use a PREEMPT_RT kernel (e.g. linux-image-rt-amd64)"
    if (realtime or "").strip() == "1" or "PREEMPT_RT" in uname_version:
        return Check(name, OK, "PREEMPT_RT")
    if "PREEMPT_DYNAMIC" in uname_version:
        mode = None
        if preempt_mode:
            m = re.search(r"\((\w+)\)", preempt_mode)
            mode = m.group(1) if m else None
        if mode is None and cmdline:
            m = re.search(r"\bpreempt=(\w+)", cmdline)
            mode = m.group(1) if m else None
        if mode is None:
            return Check(name, WARN, "PREEMPT_DYNAMIC, current mode unknown "
                         "(/sys/kernel/debug/sched/preempt not readable: mount debugfs as root)",
                         f"boot with preempt=full; {rt_advice}")
        if mode == "full":
            return Check(name, WARN, "PREEMPT_DYNAMIC, mode full (preemptible, not RT)", rt_advice)
        return Check(name, FAIL, f"PREEMPT_DYNAMIC, mode {mode}: kernel code is not preempted",
                     f"boot with preempt=full (or echo full > /sys/kernel/debug/sched/preempt); {rt_advice}")
    if re.search(r"\bPREEMPT\b", uname_version):
        return Check(name, WARN, "PREEMPT (full, not RT)", rt_advice)
    return Check(name, FAIL, "no kernel preemption (voluntary or none)", rt_advice)


def check_rtprio(soft: int, hard: int, cap_sys_nice: bool | None, priority: int) -> Check:
    value = f"RLIMIT_RTPRIO soft {format_rlimit(soft)}, hard {format_rlimit(hard)}, CAP_SYS_NICE {_yn(cap_sys_nice)}"
    if cap_sys_nice or soft == resource.RLIM_INFINITY or soft >= priority:
        return Check("rtprio", OK, value)
    return Check("rtprio", FAIL, value + f": SCHED_FIFO {priority} will be refused", RTPRIO_FIX)


def check_memlock(soft: int, cap_ipc_lock: bool | None) -> Check:
    value = f"RLIMIT_MEMLOCK {format_rlimit(soft)} bytes, CAP_IPC_LOCK {_yn(cap_ipc_lock)}"
    if cap_ipc_lock or soft == resource.RLIM_INFINITY:
        return Check("memlock", OK, value)
    return Check("memlock", FAIL, value + ": mlockall of a Python process (≥ 100 MiB) will fail", MEMLOCK_FIX)


def check_rt_throttling(runtime_us: str | None, period_us: str | None) -> Check:
    if runtime_us is None:
        return _unknown("rt_throttling", "/proc/sys/kernel/sched_rt_runtime_us")
    if runtime_us.strip() == "-1":
        return Check("rt_throttling", WARN, "off: a runaway SCHED_FIFO task can freeze a core for good",
                     "fine on a dedicated machine; keep a watchdog")
    return Check("rt_throttling", OK, f"RT tasks get {runtime_us.strip()} µs per {(period_us or '?').strip()} µs: "
                 "a loop that keeps its core busier (compute + spin_us) is stopped for the rest of the second",
                 "keep spin_us small; the run's summary reports core_busy")


def check_timer_slack(slack_ns: int | None) -> Check:
    if slack_ns is None:
        return Check("timer_slack", UNKNOWN, "prctl(PR_GET_TIMERSLACK) not available")
    if slack_ns <= 1000:
        return Check("timer_slack", OK, f"{slack_ns} ns")
    return Check("timer_slack", WARN, f"{slack_ns} ns: sleeps may wake up to {slack_ns / 1e3:g} µs late",
                 "set rtctl's timer_slack_ns = 1 (or run SCHED_FIFO, which has no slack); the spin margin hides the rest")


def check_governor(governors: dict[str, str | None]) -> Check:
    known = {cpu: g for cpu, g in governors.items() if g}
    if not known:
        return Check("cpu_governor", UNKNOWN, "no cpufreq scaling_governor readable (VM or no cpufreq driver): "
                     "the frequency is not under this kernel's control")
    slow = {cpu: g for cpu, g in known.items() if g != "performance"}
    value = ", ".join(f"{cpu} {g}" for cpu, g in sorted(known.items()))
    if not slow:
        return Check("cpu_governor", OK, value)
    return Check("cpu_governor", WARN, value + ": frequency ramps add latency",
                 "cpupower frequency-set -g performance (or echo performance > /sys/devices/system/cpu/cpu*/cpufreq/scaling_governor)")


def check_isolation(isolated: str | None, nohz_full: str | None, cmdline: str | None) -> Check:
    if isolated is None:
        return _unknown("isolated_cpus", "/sys/devices/system/cpu/isolated")
    iso, nohz = isolated.strip(), (nohz_full or "").strip()
    rcu = re.search(r"\brcu_nocbs=(\S+)", cmdline or "")
    value = f"isolated [{iso or 'none'}], nohz_full [{nohz or 'none'}], rcu_nocbs [{rcu.group(1) if rcu else 'none'}]"
    if not iso:
        return Check("isolated_cpus", WARN, value + ": the loop shares its core with everything else",
                     "boot with isolcpus=N nohz_full=N rcu_nocbs=N and pin the loop there (rtctl's cpus = [N])")
    if not nohz:
        return Check("isolated_cpus", OK, value, f"add nohz_full={iso} to stop the scheduler tick there")
    return Check("isolated_cpus", OK, value)


def check_smt(control: str | None, active: str | None) -> Check:
    if control is None:
        return _unknown("smt", "/sys/devices/system/cpu/smt/control")
    control = control.strip()
    if control in ("notsupported", "notimplemented", "off", "forceoff") or (active or "").strip() == "0":
        return Check("smt", OK, f"{control}, active {(active or '?').strip()}")
    return Check("smt", WARN, f"{control}: a sibling hyperthread slows the loop's core",
                 "boot with nosmt, or keep the loop core's sibling isolated and idle")


def check_clocksource(current: str | None) -> Check:
    if current is None:
        return _unknown("clocksource", "/sys/devices/system/clocksource/clocksource0/current_clocksource")
    cs = current.strip()
    if cs in ("tsc", "kvm-clock", "arch_sys_counter", "hyperv_clocksource_tsc_page"):
        return Check("clocksource", OK, f"{cs} (read in user space, ~20 ns)")
    return Check("clocksource", WARN, f"{cs}: every clock read is a system call or a slow bus read",
                 "use tsc if the CPU has an invariant TSC (clocksource=tsc tsc=reliable)")


def check_thp(enabled: str | None) -> Check:
    if enabled is None:
        return _unknown("transparent_hugepages", "/sys/kernel/mm/transparent_hugepage/enabled")
    m = re.search(r"\[(\w+)\]", enabled)
    mode = m.group(1) if m else enabled.strip()
    if mode == "always":
        return Check("transparent_hugepages", WARN, "always: page faults may stall on compaction",
                     "echo madvise > /sys/kernel/mm/transparent_hugepage/enabled (or transparent_hugepage=madvise)")
    return Check("transparent_hugepages", OK, mode)


def check_cpuidle(driver: str | None, exit_latencies_us: dict[str, int]) -> Check:
    if driver is None:
        return _unknown("cpu_idle", "/sys/devices/system/cpu/cpuidle/current_driver")
    if not exit_latencies_us:
        return Check("cpu_idle", OK, f"driver {driver.strip()}, no idle states exposed")
    deepest, lat = max(exit_latencies_us.items(), key=lambda kv: kv[1])
    value = f"driver {driver.strip()}, deepest {deepest} exits in {lat} µs"
    if lat <= 10:
        return Check("cpu_idle", OK, value)
    return Check("cpu_idle", WARN, value, "limit C-states (processor.max_cstate=1 intel_idle.max_cstate=1) "
                 "or hold /dev/cpu_dma_latency at 0 while running")


def check_virtualisation(hypervisor: bool) -> Check:
    if hypervisor:
        return Check("virtualisation", WARN, "running under a hypervisor: wake-ups are bounded by the host's scheduler",
                     "measure with `rtctl bench loop`; run hardware loops on bare metal")
    return Check("virtualisation", OK, "bare metal")


def _yn(flag: bool | None) -> str:
    return "unknown" if flag is None else ("yes" if flag else "no")


def _read(path: str) -> str | None:
    try:
        with open(path) as f:
            return f.read()
    except OSError:
        return None


def doctor(priority: int = 80, root: str = "/") -> list[Check]:
    """Read the live machine and check it for a SCHED_FIFO loop at ``priority`` (80: the
    documented ``[loop.rt]`` example). ``root``: where ``/proc`` and ``/sys`` are found (a
    test's fake tree); the limits, capabilities and timer slack are always this process's."""
    root = os.path.join(root, "")
    cpu = f"{root}sys/devices/system/cpu"
    cmdline = _read(f"{root}proc/cmdline")
    governors = {os.path.basename(os.path.dirname(os.path.dirname(p))): (_read(p) or "").strip() or None
                 for p in glob.glob(f"{cpu}/cpu[0-9]*/cpufreq/scaling_governor")}
    idle = {}
    for state in sorted(glob.glob(f"{cpu}/cpu0/cpuidle/state*")):
        name, latency = (_read(f"{state}/name") or "").strip(), (_read(f"{state}/latency") or "").strip()
        if name and latency.isdigit():
            idle[name] = int(latency)
    cpuinfo = _read(f"{root}proc/cpuinfo") or ""
    rtprio = resource.getrlimit(resource.RLIMIT_RTPRIO)
    return [
        check_preemption(os.uname().version, _read(f"{root}sys/kernel/realtime"),
                         _read(f"{root}sys/kernel/debug/sched/preempt"), cmdline),
        check_rtprio(rtprio[0], rtprio[1], has_capability(CAP_SYS_NICE), priority),
        check_memlock(resource.getrlimit(resource.RLIMIT_MEMLOCK)[0], has_capability(CAP_IPC_LOCK)),
        check_rt_throttling(_read(f"{root}proc/sys/kernel/sched_rt_runtime_us"),
                            _read(f"{root}proc/sys/kernel/sched_rt_period_us")),
        check_timer_slack(timer_slack_ns()),
        check_governor(governors),
        check_isolation(_read(f"{cpu}/isolated"), _read(f"{cpu}/nohz_full"), cmdline),
        check_smt(_read(f"{cpu}/smt/control"), _read(f"{cpu}/smt/active")),
        check_clocksource(_read(f"{root}sys/devices/system/clocksource/clocksource0/current_clocksource")),
        check_thp(_read(f"{root}sys/kernel/mm/transparent_hugepage/enabled")),
        check_cpuidle(_read(f"{cpu}/cpuidle/current_driver"), idle),
        check_virtualisation(re.search(r"^flags\b.*\bhypervisor\b", cpuinfo, re.M) is not None
                             or _read(f"{root}sys/hypervisor/type") is not None),
    ]


def format_doctor(checks: list[Check]) -> str:
    """A table, one row per check, each piece of advice on the line under its row."""
    w_name = max(len("check"), *(len(c.name) for c in checks))
    w_status = max(len("status"), *(len(c.status) for c in checks))
    lines = [f"{'check':<{w_name}}  {'status':<{w_status}}  value", f"{'-' * w_name}  {'-' * w_status}  -----"]
    for c in checks:
        lines.append(f"{c.name:<{w_name}}  {c.status:<{w_status}}  {c.value}")
        if c.advice:
            lines.append(f"{'':<{w_name}}  {'':<{w_status}}  → {c.advice}")
    counts = {s: sum(c.status == s for c in checks) for s in (OK, WARN, FAIL, UNKNOWN)}
    lines.append(", ".join(f"{n} {s}" for s, n in counts.items()))
    return "\n".join(lines)
