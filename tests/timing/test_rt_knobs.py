"""Real-time knobs, applied in a child process (they would change the test runner itself).

The tests check behaviour, not the environment: whatever a knob reports must match what the
process then observes, and a knob that cannot apply must leave things as they were.
"""
import json
import os
import subprocess
import sys
import textwrap

import pytest

from rtctl.errors import RealtimeError
from rtctl.timing.rt import KnobStatus, RtSettings, apply_rt

CHILD = textwrap.dedent("""
    import gc, json, os, resource, sys
    from rtctl.errors import RealtimeError
    from rtctl.timing.rt import RtSettings, apply_rt, timer_slack_ns
    args = json.loads(sys.argv[1])
    if os.sched_getscheduler(0) != os.SCHED_OTHER:  # start as a normal process, whatever ran this suite
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    for name, value in args.pop("rlimits", {}).items():   # lowering a limit needs no privilege
        resource.setrlimit(getattr(resource, name), (value, value))
    if args.pop("drop_root", False) and os.getuid() == 0:
        os.setgid(65534); os.setuid(65534)                 # loses every capability
    policy0, slack0 = os.sched_getscheduler(0), timer_slack_ns()
    enforce = args.pop("enforce", False)
    try:
        reports = [r.as_dict() for r in apply_rt(RtSettings(**args), enforce=enforce)]
        error = None
    except RealtimeError as e:
        reports, error = None, str(e)
    with open("/proc/self/status") as f:
        locked_kb = [int(l.split()[1]) for l in f if l.startswith("VmLck:")][0]
    print(json.dumps({"reports": reports, "error": error, "policy0": policy0, "slack0": slack0,
        "policy": os.sched_getscheduler(0), "priority": os.sched_getparam(0).sched_priority,
        "cpus": sorted(os.sched_getaffinity(0)), "slack": timer_slack_ns(),
        "gc_enabled": gc.isenabled(), "frozen": gc.get_freeze_count(), "locked_kb": locked_kb}))
""")


def child(**args):
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(args)], capture_output=True, text=True,
                         timeout=60, cwd="/")
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def by_knob(result):
    return {r["knob"]: r for r in result["reports"]}


pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="the knobs and /proc are Linux's")


def test_nothing_requested_reports_every_knob_off_and_changes_nothing():
    res = child()
    assert sorted(by_knob(res)) == ["cpu_affinity", "gc_freeze", "mlockall", "sched_fifo", "timer_slack"]
    assert {r["status"] for r in res["reports"]} == {"off"}
    assert (res["policy"], res["slack"], res["gc_enabled"]) == (res["policy0"], res["slack0"], True)


def test_each_report_matches_what_the_process_observes():
    cpu = sorted(os.sched_getaffinity(0))[-1]
    res = child(priority=10, cpus=[cpu], mlockall=True, timer_slack_ns=1234, gc_freeze=True)
    k = by_knob(res)
    assert k["gc_freeze"]["status"] == "applied" and not res["gc_enabled"] and res["frozen"] > 0
    assert k["cpu_affinity"]["status"] == "applied" and res["cpus"] == [cpu]
    assert k["timer_slack"]["status"] == "applied" and "1234 ns" in k["timer_slack"]["detail"]
    if k["sched_fifo"]["status"] == "applied":
        assert (res["policy"], res["priority"]) == (os.SCHED_FIFO, 10)
        assert res["slack"] in (0, 1234)  # Linux ≥ 6.7 zeroes an RT task's slack
    else:
        assert k["sched_fifo"]["status"] == "not permitted" and res["policy"] == res["policy0"]
        assert k["sched_fifo"]["fix"] and res["slack"] == 1234
    if k["mlockall"]["status"] == "applied":
        assert res["locked_kb"] > 1000  # the whole interpreter is resident and locked
    else:
        assert k["mlockall"]["status"] == "not permitted" and res["locked_kb"] == 0


def test_without_privilege_the_knobs_are_not_permitted_and_name_the_fix():
    res = child(priority=50, mlockall=True, drop_root=True,
                rlimits={"RLIMIT_RTPRIO": 0, "RLIMIT_MEMLOCK": 0})
    k = by_knob(res)
    assert k["sched_fifo"]["status"] == "not permitted" and res["policy"] == res["policy0"]
    assert "rtprio limit 0" in k["sched_fifo"]["detail"] and "rtprio 95" in k["sched_fifo"]["fix"]
    assert k["mlockall"]["status"] == "not permitted" and res["locked_kb"] == 0
    assert "memlock limit 0" in k["mlockall"]["detail"] and "LimitMEMLOCK" in k["mlockall"]["fix"]


def test_enforce_refuses_to_start_naming_each_knob_and_its_fix():
    res = child(priority=50, mlockall=True, timer_slack_ns=1, enforce=True, drop_root=True,
                rlimits={"RLIMIT_RTPRIO": 0, "RLIMIT_MEMLOCK": 0})
    assert res["reports"] is None
    assert "sched_fifo: not permitted: rtprio limit 0" in res["error"]
    assert "mlockall: not permitted" in res["error"] and "timer_slack" not in res["error"]
    assert "/etc/security/limits.conf" in res["error"]


@pytest.mark.parametrize("settings, knob", [
    (RtSettings(priority=100), "sched_fifo"),
    (RtSettings(priority=-3), "sched_fifo"),
    (RtSettings(cpus=(4095,)), "cpu_affinity"),
    (RtSettings(timer_slack_ns=-1), "timer_slack"),
])
def test_impossible_values_fail_before_touching_the_process(settings, knob):
    # safe in-process: each fails validation or is refused by the kernel, changing nothing
    report = {r.knob: r for r in apply_rt(settings)}[knob]
    assert report.status is KnobStatus.FAILED and report.fix
    with pytest.raises(RealtimeError, match=knob):
        apply_rt(settings, enforce=True)


def test_zero_values_leave_the_knobs_alone_and_any_object_with_the_fields_will_do():
    class LoopRt:  # e.g. the run configuration's [loop.rt], which has its own dataclass
        priority, cpus, mlockall, timer_slack_ns, gc_freeze = 0, (), False, 0, False

    assert {r.status for r in apply_rt(LoopRt(), enforce=True)} == {KnobStatus.OFF}


def test_sched_fifo_takes_both_ends_of_the_priority_range_and_nothing_beyond(monkeypatch):
    """In-process with the kernel call replaced (the runner must not become SCHED_FIFO)."""
    from rtctl.timing import rt

    lo, hi = os.sched_get_priority_min(os.SCHED_FIFO), os.sched_get_priority_max(os.SCHED_FIFO)
    asked = []
    monkeypatch.setattr(os, "sched_setscheduler", lambda pid, policy, param: asked.append(param.sched_priority))
    monkeypatch.setattr(os, "sched_getparam", lambda pid: os.sched_param(asked[-1]))
    for priority in (lo, hi):
        assert rt._fifo(priority).status is KnobStatus.APPLIED
    for priority in (lo - 1, hi + 1):
        report = rt._fifo(priority)
        assert report.status is KnobStatus.FAILED and f"{lo}..{hi}" in report.detail
    assert asked == [lo, hi]


def test_a_refused_fifo_blames_the_soft_rtprio_limit_when_it_is_too_low(monkeypatch):
    from rtctl.timing import rt

    def refuse(pid, policy, param):
        raise PermissionError

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(rt, "has_capability", lambda bit: False)
    monkeypatch.setattr(rt.resource, "getrlimit", lambda which: (10, 99))  # soft 10, hard 99
    report = rt._fifo(80)
    assert report.status is KnobStatus.NOT_PERMITTED and report.detail.startswith("rtprio limit 10 < 80")
    monkeypatch.setattr(rt.resource, "getrlimit", lambda which: (99, 99))
    assert "cgroup" in rt._fifo(80).detail  # the limit allows it: the kernel refused for another reason
