"""Tests for timing mutants that survived the run of every mutant (docs/mutation/timing.md), part 2:
the core-busy meter (rtctl/timing/busy.py), the tick's compiled bookkeeping
(rtctl/timing/record.py) and the real-time knobs (rtctl/timing/rt.py), each against the
documented behaviour or Linux's:

* ``rt_budget``: a runtime of 0 is a budget of 0, a period of 0 gives no budget, a period of
  1 µs is a period;
* the meter's window is Linux's default ``sched_rt_period_us`` (1 s); ``window_ns`` must be
  > 0 and 1 ns will do;
* the warning: above 80 % of the budget (not at it), at most one per 10 s (a warning 10 s
  after the last one is allowed, 1 ns sooner it is not);
* shares are rounded to 0.001, in the warning and the summary; a summary at the start instant
  has no mean;
* ``bit_length`` is ``int.bit_length`` from 0; a phase not marked in a tick counts 0 even when
  its stamp from the last tick equals the wake (a clock that did not move);
* the knobs, in-process with the kernel calls replaced: each bit of CapEff (CAP_IPC_LOCK 14,
  CAP_SYS_NICE 23) and an unreadable status file; a priority up to the soft rtprio limit is
  allowed by it; the reports give this process's priority and CPUs (pid 0), the soft memlock
  limit and, from the real libc in a child, the kernel's errno; timer slack 1 ns … 1 ms;
  mlockall's flags per architecture; settings and reports are values; ``enforce`` is named.
"""
import dataclasses
import errno
import importlib.util
import io
import os
import platform
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import structlog

from rtctl.timing import record, rt
from rtctl.timing.busy import WARN_FRACTION, BusyMeter, rt_budget
from rtctl.timing.clock import FakeClock
from rtctl.timing.rt import KnobReport, KnobStatus, RtSettings, apply_rt
from rtctl.timing.scheduler import Ticker

S = 1_000_000_000
WARNING = "loop keeps its core busy"


class FakeCpu:
    """The loop thread's CPU clock, advanced by the test."""

    def __init__(self, ns=0):
        self.ns = ns

    def __call__(self):
        return self.ns


def _budget(tmp_path, runtime, period):
    (tmp_path / "runtime").write_text(runtime)
    (tmp_path / "period").write_text(period)
    return rt_budget(str(tmp_path / "runtime"), str(tmp_path / "period"))


def test_a_runtime_of_zero_is_a_budget_of_zero(tmp_path):
    """Linux: sched_rt_runtime_us = 0 gives SCHED_FIFO threads no time at all (only -1 is no limit)."""
    assert _budget(tmp_path, "0\n", "1000000\n") == 0.0


def test_a_period_of_zero_has_no_budget(tmp_path):
    assert _budget(tmp_path, "950000\n", "0\n") is None


def test_a_period_of_one_microsecond_is_a_period(tmp_path):
    """sched_rt_period_us takes 1 … INT_MAX (Documentation/scheduler/sched-rt-group.rst)."""
    assert _budget(tmp_path, "1\n", "1\n") == 1.0


def test_the_default_window_is_linux_s_default_rt_period_of_one_second():
    """Linux's default sched_rt_period_us is 1 000 000 µs: a window closes 1 s after the start, not before."""
    cpu = FakeCpu()
    meter = BusyMeter(cpu_clock=cpu)
    meter.start(0)
    meter.sample(S - 1)
    assert meter.windows == 0
    meter.sample(S)
    assert meter.windows == 1


def test_a_window_must_be_positive_and_one_nanosecond_will_do():
    with pytest.raises(ValueError):
        BusyMeter(window_ns=0)
    with pytest.raises(ValueError):
        BusyMeter(window_ns=-1)
    cpu = FakeCpu()
    meter = BusyMeter(cpu_clock=cpu, window_ns=1)
    meter.start(10)
    cpu.ns = 1
    meter.sample(11)
    assert meter.windows == 1 and meter.max_share == 1.0


def _warned_at(meter, cpu, times):
    """Sample a fully busy core at each time; the times a warning came."""
    warned, wall = [], 0
    with structlog.testing.capture_logs() as logs:
        for t in times:
            cpu.ns += t - wall  # the thread on its core all the time
            wall = t
            n = len(logs)
            meter.sample(t)
            if any(e["event"] == WARNING for e in logs[n:]):
                warned.append(t)
    return warned


def test_a_warning_comes_again_ten_seconds_after_the_last_and_not_sooner():
    """At most one warning per 10 s: exactly 10 s later is the next allowed; 10 s − 1 ns is too soon."""
    cpu = FakeCpu()
    meter = BusyMeter(limit=0.95, cpu_clock=cpu, window_ns=1)
    meter.start(0)
    times = [S, 11 * S - 1, 11 * S, 21 * S - 1, 21 * S]
    assert _warned_at(meter, cpu, times) == [S, 11 * S, 21 * S]


def test_a_window_at_exactly_the_warning_fraction_does_not_warn():
    """'more than this fraction of the budget': 0.4 of the core against a budget of 0.5 is at 80 %, not over."""
    cpu = FakeCpu()
    meter = BusyMeter(limit=0.5, cpu_clock=cpu, window_ns=5)
    meter.start(0)
    assert 2 / 5 == WARN_FRACTION * 0.5  # the share below is exactly at the threshold
    with structlog.testing.capture_logs() as logs:
        cpu.ns = 2
        meter.sample(5)  # 2 ns of CPU in 5 ns: 0.4
        assert logs == []
        cpu.ns = 5
        meter.sample(10)  # 3 in 5: 0.6, over
    assert [e["event"] for e in logs] == [WARNING]


def test_the_warning_gives_the_share_and_the_budget_to_a_thousandth():
    cpu = FakeCpu()
    meter = BusyMeter(limit=2 / 3, cpu_clock=cpu, window_ns=6)
    meter.start(0)
    with structlog.testing.capture_logs() as logs:
        cpu.ns = 5
        meter.sample(6)  # 5/6 of the core
    (warning,) = logs
    assert (warning["share"], warning["budget"]) == (0.833, 0.667)


def test_the_summary_gives_shares_to_a_thousandth():
    cpu = FakeCpu()
    meter = BusyMeter(limit=2 / 3, cpu_clock=cpu, window_ns=3)
    meter.start(0)
    cpu.ns = 1
    meter.sample(3)  # one window: 1/3
    assert meter.summary(6) == {"mean": 0.167, "max": 0.333, "budget": 0.667}  # mean 1 ns in 6


def test_a_summary_at_the_start_instant_has_no_mean():
    cpu = FakeCpu(123)
    meter = BusyMeter(cpu_clock=cpu)
    meter.start(5_000)
    assert meter.summary(5_000) == {"mean": None, "max": None, "budget": None}


def test_bit_length_is_int_bit_length_from_zero():
    """The docstring: int.bit_length of 0 ≤ x < 2⁶³ (plain Python when called from Python)."""
    xs = list(range(0, 300)) + [(1 << k) + d for k in range(1, 63) for d in (-1, 0, 1)] + [(1 << 63) - 1]
    assert [record.bit_length(x) for x in xs] == [x.bit_length() for x in xs]


def test_a_phase_not_marked_counts_zero_when_its_old_stamp_equals_the_wake():
    """Lock-step on a clock that does not move between ticks: phase b, marked last tick at the
    instant the next tick wakes, is not marked this tick and takes 0 (it took −7 ns before)."""
    clock = FakeClock(0)
    ticker = Ticker(1_000_000, clock=clock, realtime_factor=0, phases=("a", "b"))
    ticker.start()
    ticker.wait()
    clock.advance(10)
    ticker.mark(0)
    clock.advance(10)
    ticker.mark(1)
    ticker.end_tick()
    assert ticker.phase_ns.tolist() == [10, 10]
    ticker.wait()  # wakes at 20, b's stamp
    clock.advance(7)
    ticker.mark(0)
    ticker.end_tick()
    assert ticker.phase_ns.tolist() == [7, 0]



# --- rtctl/timing/rt.py: the knobs, in-process with the kernel calls replaced -------------------

EVERY_CAP = (1 << 41) - 1  # CAP_CHOWN (0) … CAP_CHECKPOINT_RESTORE (40), Linux ≥ 5.9


def _cap_eff(monkeypatch, eff: int):
    """/proc/self/status with this effective set (and every capability permitted), as Linux writes it."""
    text = f"Name:\tpython3\nCapInh:\t{0:016x}\nCapPrm:\t{EVERY_CAP:016x}\nCapEff:\t{eff:016x}\n"

    def fake_open(path, *args, **kw):
        assert path == "/proc/self/status"
        return io.StringIO(text)

    monkeypatch.setattr(rt, "open", fake_open, raising=False)


@pytest.mark.parametrize("eff, present", [
    (1 << 23, {23}),
    (EVERY_CAP & ~(1 << 24), set(range(41)) - {24}),  # root in a container without CAP_SYS_RESOURCE
    (0x3000, {12, 13}),
])
def test_has_capability_reads_each_bit_of_the_effective_set(monkeypatch, eff, present):
    _cap_eff(monkeypatch, eff)
    assert {bit for bit in range(64) if rt.has_capability(bit)} == present


def test_an_unreadable_status_file_makes_a_capability_unknown(monkeypatch):
    def no_proc(path, *args, **kw):
        raise FileNotFoundError(path)

    monkeypatch.setattr(rt, "open", no_proc, raising=False)
    assert rt.has_capability(23) is None


def _refused_fifo(monkeypatch, soft_rtprio):
    def refuse(pid, policy, param):
        raise PermissionError

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(rt.resource, "getrlimit", lambda which: (soft_rtprio, 99))


@pytest.mark.parametrize("eff, blamed", [(1 << 23, "cgroup"), (EVERY_CAP & ~(1 << 23), "rtprio limit 10 < 80")])
def test_a_refused_fifo_with_cap_sys_nice_blames_the_cgroup_not_the_limit(monkeypatch, eff, blamed):
    """CAP_SYS_NICE is capability 23 (linux/capability.h): with it the rtprio limit does not apply."""
    _refused_fifo(monkeypatch, 10)
    _cap_eff(monkeypatch, eff)
    assert blamed in rt._fifo(80).detail


def test_a_priority_equal_to_the_rtprio_limit_is_allowed_by_it(monkeypatch):
    """sched_setscheduler(2): an unprivileged thread may take priorities up to RLIMIT_RTPRIO."""
    _refused_fifo(monkeypatch, 80)
    _cap_eff(monkeypatch, 0)
    report = rt._fifo(80)
    assert report.status is KnobStatus.NOT_PERMITTED and "cgroup" in report.detail


def test_the_fifo_report_gives_this_process_s_priority(monkeypatch):
    """pid 0 is the calling process; pid 1 (init) runs SCHED_OTHER, priority 0."""
    prio = {}
    monkeypatch.setattr(os, "sched_setscheduler", lambda pid, policy, param: prio.update({pid: param.sched_priority}))
    monkeypatch.setattr(os, "sched_getparam", lambda pid: os.sched_param(prio.get(pid, 0)))
    assert rt._fifo(80).detail == "SCHED_FIFO priority 80"


def _cpus(monkeypatch, mine, refuse=None):
    """This process may run on ``mine``; init (pid 1) on 8 CPUs."""
    allowed = {0: set(mine), 1: set(range(8))}

    def set_affinity(pid, cpus):
        if refuse:
            raise refuse
        allowed[pid] = set(cpus)

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: allowed[pid])
    monkeypatch.setattr(os, "sched_setaffinity", set_affinity)


def test_the_affinity_report_gives_this_process_s_cpus(monkeypatch):
    _cpus(monkeypatch, {0, 1})
    assert rt._affinity((1,)).detail == "CPUs [1]"


def test_a_failed_affinity_names_the_cpus_this_process_may_use(monkeypatch):
    _cpus(monkeypatch, {0, 1}, refuse=OSError(errno.EINVAL, os.strerror(errno.EINVAL)))
    report = rt._affinity((7,))
    assert report.status is KnobStatus.FAILED and report.detail.endswith("allowed [0, 1]")
    assert report.fix == "choose CPUs among [0, 1]"


class FakeLibc:
    """mlockall refused; prctl's timer slack kept as Linux keeps it."""

    def __init__(self):
        self.mlockall_flags, self.slack = [], 50_000

    def mlockall(self, flags):
        self.mlockall_flags.append(flags)
        return -1

    def prctl(self, option, arg2, *unused):
        if option == rt.PR_SET_TIMERSLACK:
            self.slack = arg2.value
            return 0
        assert option == rt.PR_GET_TIMERSLACK
        return self.slack


@pytest.fixture
def libc(monkeypatch):
    fake = FakeLibc()
    monkeypatch.setattr(rt, "_libc", lambda: fake)
    monkeypatch.setattr(rt.platform, "system", lambda: "Linux")
    return fake


@pytest.mark.parametrize("eff, word", [(1 << 14, "present"), (EVERY_CAP & ~(1 << 14), "absent")])
def test_a_refused_mlockall_gives_the_soft_memlock_limit_and_cap_ipc_lock(monkeypatch, libc, eff, word):
    """CAP_IPC_LOCK is capability 14 (linux/capability.h); the limit that applies is the soft one."""
    monkeypatch.setattr(rt.ctypes, "get_errno", lambda: errno.EPERM)
    monkeypatch.setattr(rt.resource, "getrlimit", lambda which: (0, rt.resource.RLIM_INFINITY))
    _cap_eff(monkeypatch, eff)
    report = rt._mlockall()
    assert report.status is KnobStatus.NOT_PERMITTED
    assert report.detail == f"{os.strerror(errno.EPERM)}: memlock limit 0 bytes, CAP_IPC_LOCK {word}"


@pytest.mark.parametrize("ns, applied", [(0, False), (1, True), (1_000_000, True), (1_000_001, False)])
def test_the_timer_slack_takes_one_nanosecond_to_one_millisecond(libc, ns, applied):
    """RtSettings: 1 ns … 1 ms (0 would ask the kernel for its default)."""
    report = rt._timer_slack(ns)
    assert (report.status is KnobStatus.APPLIED) == applied
    assert libc.slack == (ns if applied else 50_000)


def _mcl_on(monkeypatch, machine):
    """mlockall's flags as a fresh copy of rt.py works them out on this machine."""
    monkeypatch.setattr(platform, "machine", lambda: machine)
    spec = importlib.util.spec_from_file_location("rt_elsewhere", rt.__file__)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)  # (its dataclasses look themselves up there)
    spec.loader.exec_module(module)
    return module._MCL


@pytest.mark.parametrize("machine, flags", [
    ("x86_64", 1 | 2), ("aarch64", 1 | 2), ("armv7l", 1 | 2), ("riscv64", 1 | 2),  # asm-generic/mman-common.h
    ("ppc64le", 0x2000 | 0x4000), ("sparc64", 0x2000 | 0x4000), ("alpha", 8192 | 16384),  # their asm/mman.h
])
def test_mlockall_asks_for_current_and_future_pages_with_the_architecture_s_flags(monkeypatch, machine, flags):
    assert _mcl_on(monkeypatch, machine) == flags


def test_a_refused_mlockall_gives_the_kernel_s_reason():
    """Real libc in a child without CAP_IPC_LOCK and a memlock limit of 0: mlockall(2) says EPERM."""
    child = textwrap.dedent("""
        import os, resource
        from rtctl.timing import rt
        resource.setrlimit(resource.RLIMIT_MEMLOCK, (0, 0))
        if os.getuid() == 0:
            os.setgid(65534); os.setuid(65534)  # loses every capability
        print(rt._mlockall().detail)
    """)
    out = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=60,
                         cwd=str(Path(rt.__file__).parents[2]))
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith(os.strerror(errno.EPERM) + ": memlock limit 0 bytes")


def test_settings_and_reports_are_values():
    settings, report = RtSettings(priority=80), KnobReport("mlockall", KnobStatus.OFF, "not requested")
    for value, field in ((settings, "priority"), (report, "status")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, field, None)
    assert {settings, RtSettings(priority=80)} == {settings} and len({report, report}) == 1


def test_enforce_is_named_never_positional():
    with pytest.raises(TypeError):
        apply_rt(RtSettings(), True)
