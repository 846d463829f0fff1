"""doctor's verdicts from what a machine shows, and its run on this one."""
import resource

import pytest

from rtctl.timing import doctor as d

INF = resource.RLIM_INFINITY
DYN = "#1 SMP PREEMPT_DYNAMIC Thu Jan  1 00:00:00 UTC 2026"


@pytest.mark.parametrize("uname, realtime, mode, cmdline, status, words", [
    ("#1 SMP PREEMPT_RT Thu", None, None, None, "ok", "PREEMPT_RT"),
    ("#1 SMP PREEMPT_DYNAMIC", "1", None, None, "ok", "PREEMPT_RT"),  # /sys/kernel/realtime says so
    (DYN, None, "none voluntary (full) lazy\n", None, "warn", "mode full"),
    (DYN, None, "none (voluntary) full\n", None, "fail", "mode voluntary"),
    (DYN, None, None, "root=/dev/sda preempt=none quiet", "fail", "mode none"),
    (DYN, None, None, "quiet", "warn", "mode unknown"),
    ("#1 SMP PREEMPT Mon", None, None, None, "warn", "PREEMPT (full"),
    ("#1 SMP Mon Jan 1", None, None, None, "fail", "no kernel preemption"),
])
def test_preemption_model(uname, realtime, mode, cmdline, status, words):
    c = d.check_preemption(uname, realtime, mode, cmdline)
    assert c.status == status and words in c.value
    assert (c.advice == "") == (status == "ok")


def test_rtprio_needs_the_limit_or_the_capability():
    assert d.check_rtprio(0, 0, True, 80).status == "ok"
    assert d.check_rtprio(95, 95, False, 80).status == "ok"
    assert d.check_rtprio(INF, INF, None, 80).status == "ok"
    c = d.check_rtprio(0, 0, False, 80)
    assert c.status == "fail" and "soft 0" in c.value and "rtprio 95" in c.advice
    assert d.check_rtprio(50, 99, False, 80).status == "fail"


def test_memlock():
    assert d.check_memlock(INF, False).status == "ok"
    assert d.check_memlock(8 << 20, True).status == "ok"
    c = d.check_memlock(8 << 20, False)
    assert c.status == "fail" and "8388608" in c.value and "LimitMEMLOCK" in c.advice


def test_timer_slack_and_throttling():
    assert d.check_timer_slack(50_000).status == "warn"
    assert d.check_timer_slack(1).status == "ok"
    assert d.check_timer_slack(None).status == "unknown"
    assert d.check_rt_throttling("950000\n", "1000000\n").status == "ok"
    assert d.check_rt_throttling("-1\n", "1000000\n").status == "warn"
    assert d.check_rt_throttling(None, None).status == "unknown"


def test_governor():
    assert d.check_governor({}).status == "unknown"
    assert d.check_governor({"cpu0": None}).status == "unknown"
    assert d.check_governor({"cpu0": "performance", "cpu1": "performance"}).status == "ok"
    c = d.check_governor({"cpu0": "performance", "cpu1": "powersave"})
    assert c.status == "warn" and "cpu1 powersave" in c.value and "cpupower" in c.advice


def test_isolation():
    assert d.check_isolation(None, None, None).status == "unknown"
    c = d.check_isolation("\n", None, "quiet")
    assert c.status == "warn" and "isolcpus" in c.advice
    c = d.check_isolation("3\n", "3\n", "isolcpus=3 nohz_full=3 rcu_nocbs=3")
    assert c.status == "ok" and "rcu_nocbs [3]" in c.value and not c.advice
    assert "nohz_full=3" in d.check_isolation("3\n", "\n", "isolcpus=3").advice


@pytest.mark.parametrize("control, active, status", [
    ("notsupported", "0", "ok"), ("off", "0", "ok"), ("on", "1", "warn"), ("on", "0", "ok"), (None, None, "unknown"),
])
def test_smt(control, active, status):
    assert d.check_smt(control, active).status == status


def test_clocksource_thp_idle_virtualisation():
    assert d.check_clocksource("tsc\n").status == "ok"
    assert d.check_clocksource("hpet\n").status == "warn"
    assert d.check_clocksource(None).status == "unknown"
    assert d.check_thp("[always] madvise never\n").status == "warn"
    assert d.check_thp("always [madvise] never\n").value == "madvise"
    assert d.check_cpuidle("none\n", {}).status == "ok"
    c = d.check_cpuidle("intel_idle\n", {"POLL": 0, "C1": 2, "C6": 133})
    assert c.status == "warn" and "C6 exits in 133" in c.value
    assert d.check_cpuidle("intel_idle\n", {"POLL": 0, "C1": 2}).status == "ok"
    assert d.check_virtualisation(True).status == "warn"


def test_doctor_on_this_machine_reports_every_check_with_a_valid_status():
    checks = d.doctor()
    names = [c.name for c in checks]
    assert names[:3] == ["preemption", "rtprio", "memlock"] and len(set(names)) == len(names) >= 10
    assert {c.status for c in checks} <= {"ok", "warn", "fail", "unknown"}
    assert all(c.value for c in checks)
    assert all(c.advice for c in checks if c.status in ("warn", "fail"))


def test_format_doctor_puts_one_check_per_row_and_advice_under_it():
    checks = [d.Check("preemption", "warn", "PREEMPT_DYNAMIC, mode full", "use PREEMPT_RT"),
              d.Check("smt", "ok", "off")]
    lines = d.format_doctor(checks).splitlines()
    assert lines[0].split() == ["check", "status", "value"]
    assert lines[2].split()[:2] == ["preemption", "warn"] and lines[3].strip() == "→ use PREEMPT_RT"
    assert lines[4].split() == ["smt", "ok", "off"]
    assert lines[-1] == "1 ok, 1 warn, 0 fail, 0 unknown"
    assert lines[2].index("PREEMPT") == lines[4].index("off")  # aligned value column
