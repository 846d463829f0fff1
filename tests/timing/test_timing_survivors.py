"""Tests for timing mutants that survived the suite (docs/mutation/timing.md), each against the
documented behaviour:

* values below 64 ns are exact in the loop statistics (rtctl/timing/stats.py), down to 1 ns,
  and the summary's µs keep them to the nanosecond;
* the core-busy mean exists as soon as any wall time has passed;
* without libc's clock_nanosleep (a libc that lacks it) the clock falls back to time.sleep;
* the overrun warning's wake lateness is in µs;
* doctor: the live preemption mode wins over the boot parameter, an unknown capability reads
  "unknown", and ``doctor()`` reads the idle states, the RT priority limit (against priority
  80, the documented example) and the memlock soft limit from the machine it is given, its
  governors and a hypervisor (by the CPU flag or sysfs); a value says "?" or "none" for what
  was not readable, and a check is an immutable value.
"""
import ctypes
import dataclasses
import os
import resource

import pytest
import structlog

from rtctl.timing import clock as clock_module
from rtctl.timing import doctor as d
from rtctl.timing.busy import BusyMeter
from rtctl.timing.clock import FakeClock, MonotonicClock
from rtctl.timing.scheduler import Ticker
from rtctl.timing.stats import LoopStats

INF = resource.RLIM_INFINITY


@pytest.mark.parametrize("ns", [0, 1, 2, 37, 63])
def test_a_value_below_64_ns_is_exact_in_the_percentiles_and_the_summary(ns):
    stats = LoopStats(("a",))
    stats.record(ns, [ns], ns)
    assert stats.percentiles_ns("tick")["p50"] == stats.percentiles_ns("wake_lateness")["p50"] == ns
    summary = stats.summary(1.0, 0.001, 1.0)
    assert summary["compute_us"]["a"]["p50"] == summary["wake_lateness_us"]["p99"] == ns / 1000


def test_the_busy_mean_exists_one_nanosecond_after_the_start():
    cpu = iter([5, 6])
    meter = BusyMeter(cpu_clock=lambda: next(cpu))
    meter.start(1_000)
    assert meter.summary(1_001)["mean"] == 1.0  # 1 ns of CPU in 1 ns of wall time


def test_a_libc_without_clock_nanosleep_falls_back_to_time_sleep(monkeypatch):
    class LibcWithoutIt:
        def __init__(self, *args, **kw):
            pass

        def __getattr__(self, name):
            raise AttributeError(name)  # what ctypes raises for a symbol the library lacks

    monkeypatch.setattr(ctypes, "CDLL", LibcWithoutIt)
    assert clock_module._load_clock_nanosleep() is None
    clock = MonotonicClock(0)
    deadline = clock.now_ns() + 1_000_000
    clock.sleep_until_ns(deadline)
    assert clock.now_ns() >= deadline


def test_the_overrun_warning_gives_the_wake_lateness_in_microseconds():
    clock = FakeClock(0, wake_latency_ns=30_000)
    ticker = Ticker(1_000_000, clock=clock, max_consecutive_overruns=10**9)
    ticker.start()
    with structlog.testing.capture_logs() as logs:
        for _ in range(2):
            ticker.wait()
            clock.advance(1_500_000)  # every tick overruns
            ticker.end_tick()
    first = next(r for r in logs if r["event"] == "tick overrun")
    assert first["wake_lateness_us"] == 30.0


def test_the_live_preemption_mode_wins_over_the_boot_parameter():
    dyn = "#1 SMP PREEMPT_DYNAMIC Thu Jan  1 00:00:00 UTC 2026"
    c = d.check_preemption(dyn, None, "none voluntary (full) lazy\n", "root=/dev/sda preempt=none")
    assert c.status == "warn" and "mode full" in c.value


def test_an_unknown_capability_reads_unknown():
    assert d.check_rtprio(INF, INF, None, 80).value.endswith("CAP_SYS_NICE unknown")
    assert d.check_memlock(INF, None).value.endswith("CAP_IPC_LOCK unknown")
    assert d.check_rtprio(0, 0, False, 80).value.startswith("RLIMIT_RTPRIO soft 0, hard 0, CAP_SYS_NICE no")


def _machine(root, files: dict[str, str]) -> str:
    for path, text in files.items():
        (root / path).parent.mkdir(parents=True, exist_ok=True)
        (root / path).write_text(text)
    return str(root)


def _limits(monkeypatch, rtprio, memlock):
    limits = {resource.RLIMIT_RTPRIO: rtprio, resource.RLIMIT_MEMLOCK: memlock}
    monkeypatch.setattr(d.resource, "getrlimit", lambda which: limits[which])
    monkeypatch.setattr(d, "has_capability", lambda cap: False)


def test_doctor_reads_the_idle_states_of_the_machine_it_is_given(tmp_path, monkeypatch):
    _limits(monkeypatch, (INF, INF), (INF, INF))
    cpuidle = "sys/devices/system/cpu/cpu0/cpuidle"
    root = _machine(tmp_path, {
        "sys/devices/system/cpu/cpuidle/current_driver": "intel_idle\n",
        f"{cpuidle}/state0/name": "POLL\n", f"{cpuidle}/state0/latency": "0\n",
        f"{cpuidle}/state1/name": "C6\n", f"{cpuidle}/state1/latency": "133\n",
        f"{cpuidle}/state2/latency": "900\n",  # no name: not a state
        f"{cpuidle}/state3/name": "\n", f"{cpuidle}/state3/latency": "900\n",  # an empty name: neither
        f"{cpuidle}/state4/name": "C10\n", f"{cpuidle}/state4/latency": "n/a\n",  # no number: skipped
    })
    idle = next(c for c in d.doctor(root=root) if c.name == "cpu_idle")
    assert (idle.status, idle.value) == ("warn", "driver intel_idle, deepest C6 exits in 133 µs")


@pytest.mark.parametrize("rtprio, status", [((80, 80), "ok"), ((79, 99), "fail")])
def test_doctor_judges_the_soft_rtprio_limit_against_priority_80(tmp_path, monkeypatch, rtprio, status):
    _limits(monkeypatch, rtprio, (INF, INF))
    check = next(c for c in d.doctor(root=str(tmp_path)) if c.name == "rtprio")
    assert check.status == status
    assert check.value.startswith(f"RLIMIT_RTPRIO soft {rtprio[0]}, hard {rtprio[1]}")


def test_doctor_judges_the_soft_memlock_limit(tmp_path, monkeypatch):
    _limits(monkeypatch, (INF, INF), (64 << 10, INF))
    check = next(c for c in d.doctor(root=str(tmp_path)) if c.name == "memlock")
    assert check.status == "fail" and check.value.startswith("RLIMIT_MEMLOCK 65536 bytes")


def test_doctor_on_an_empty_tree_reads_nothing_from_this_machine(tmp_path, monkeypatch):
    _limits(monkeypatch, (INF, INF), (INF, INF))
    checks = {c.name: c for c in d.doctor(root=str(tmp_path))}
    for name in ("rt_throttling", "clocksource", "transparent_hugepages", "cpu_idle", "smt"):
        assert checks[name].status == "unknown", checks[name]
    assert os.path.isdir("/proc")  # (this machine has them: the answers came from the tree)


def test_doctor_values_say_what_was_not_readable():
    assert d.check_rt_throttling("950000\n", None).value.startswith("RT tasks get 950000 µs per ? µs: ")
    assert d.check_smt("off\n", None).value == "off, active ?"
    assert d.check_isolation("", None, None).value.startswith("isolated [none], nohz_full [none], rcu_nocbs [none]:")
    assert d.check_isolation("3\n", "3\n", "quiet rcu_nocbs=3").value == "isolated [3], nohz_full [3], rcu_nocbs [3]"
    assert d.check_timer_slack(50_500).value == "50500 ns: sleeps may wake up to 50.5 µs late"
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.check_timer_slack(1).status = "fail"


def test_doctor_reads_the_governors_of_the_machine_it_is_given(tmp_path, monkeypatch):
    _limits(monkeypatch, (INF, INF), (INF, INF))
    cpu = "sys/devices/system/cpu"
    root = _machine(tmp_path, {f"{cpu}/cpu0/cpufreq/scaling_governor": "performance\n",
                               f"{cpu}/cpu1/cpufreq/scaling_governor": "powersave\n",
                               f"{cpu}/cpu2/cpufreq/scaling_governor": "\n"})  # (empty: not known)
    (tmp_path / cpu / "cpu3" / "cpufreq" / "scaling_governor").mkdir(parents=True)  # not readable
    governor = next(c for c in d.doctor(root=root) if c.name == "cpu_governor")
    assert governor.status == "warn" and governor.value.startswith("cpu0 performance, cpu1 powersave:")


@pytest.mark.parametrize("files, status", [
    ({"proc/cpuinfo": "processor : 0\nflags : fpu vme hypervisor lm\n"}, "warn"),
    ({"proc/cpuinfo": "processor : 0\nflags : fpu vme lm\n", "sys/hypervisor/type": "xen\n"}, "warn"),
    ({"proc/cpuinfo": "processor : 0\nflags : fpu vme lm\n"}, "ok"),
], ids=["cpu flag", "sysfs", "bare metal"])
def test_doctor_sees_a_hypervisor_by_the_cpu_flag_or_sysfs(tmp_path, monkeypatch, files, status):
    _limits(monkeypatch, (INF, INF), (INF, INF))
    check = next(c for c in d.doctor(root=_machine(tmp_path, files)) if c.name == "virtualisation")
    assert check.status == status
