"""`rtctl bench soak` for 30 s (the 10-minute figures are measured with the same command): the
full stack over HIL — hil-sim with CiA 402 and MIT drives on two socketcand buses, the daemon
with telemetry — holds its memory, runs no garbage collection, records every tick and leaves
every drive disabled."""
import json

import pytest

from hil_helpers import VmStall, rtctl

pytestmark = [pytest.mark.hil, pytest.mark.soak]


def test_a_30_s_soak_holds_the_four_facts(tmp_path):
    out = tmp_path / "soak.json"
    result = rtctl("bench", "soak", "--minutes", 0.5, "--json", out, timeout=240)
    assert result.returncode == 0, result.stderr[-3000:]
    r = json.loads(out.read_text())
    print(result.stdout)
    assert r["exit_code"] == 0 and r["stop_reason"] == "duration reached", (r["stop_reason"], r["device_errors"])
    if r["ticks"] < 0.8 * 30 * 500:  # it ran, paced at 500 Hz (a skipped period is not a tick)
        raise VmStall(f"{r['overruns']} overruns: {r['ticks']} ticks in 30 s")
    assert r["rss_growth_bytes"] <= 1 << 20, r["rss_growth_bytes"]
    assert r["gc_collections"] == 0
    assert r["telemetry_rows"] == r["ticks"] and r["dropped_rows"] == 0
    assert r["drives"] == 6 and r["drives_enabled"] == 0, (r["drives_left_enabled"], r["motor_events"][-12:])
    assert [m["minute"] for m in r["per_minute"]] == [1] and r["per_minute"][0]["ticks"] == r["ticks"]
