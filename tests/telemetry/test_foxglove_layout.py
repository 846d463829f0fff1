"""The shipped Foxglove layout for the PUMA jobs: what it plots is what the jobs publish.

Every plotted path (``/topic.field[index]``) names a channel that some PUMA job's live view and
MCAP export carry, a field of that channel's JSON Schema and an index inside the recorded
column; every channel of the computed-torque and C* jobs is shown somewhere; the file is what
scripts/foxglove_layout.py writes (so it is regenerated, not edited by hand)."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from rtctl.config import load_config
from rtctl.runtime import build
from rtctl.telemetry.channels import EVENTS, topics
from rtctl.timing import DAEMON_PHASES

ROOT = Path(__file__).resolve().parents[2]
LAYOUT = ROOT / "configs" / "foxglove" / "puma_layout.json"
JOBS = ("puma560_sim", "puma560_cstar_sim", "puma560_vision_sim", "puma560_switch_sim")
PATH = re.compile(r"^(/[\w/]+)\.(\w+)(?:\[(\d+)\])?$")


def recorded_shapes(job: str) -> tuple[dict, dict]:
    """The telemetry columns a run of ``job`` records ({name: per-row shape}) and its metadata,
    as the daemon lays them out: the state columns, each controller's internals, which are active
    (the tunable parameters' columns are not channels: their changes are events)."""
    cfg = load_config(ROOT / "configs" / f"{job}.toml", sim=True)
    n = cfg.model.nq
    shapes = {"t": (), "q": (n,), "qd": (n,), "q_des": (n,), "qd_des": (n,), "tau": (n,),
              "phase_ns": (len(DAEMON_PHASES),)}
    configured = build(cfg).configured
    for c in configured:
        shapes.update({name: arr.shape for name, arr in c.internals.items()})
    shapes["controllers_active"] = (len(configured),)
    return shapes, {"phases": list(DAEMON_PHASES), "joints": list(cfg.model.joint_names)}


@pytest.fixture(scope="module")
def published():
    """{topic: (schema, {field: length or None for a scalar})} over every PUMA job."""
    out = {}
    for job in JOBS:
        shapes, meta = recorded_shapes(job)
        for topic in topics(shapes, meta):
            fields = {f.key: (None if f.index is not None or not shapes[f.column] else shapes[f.column][0])
                      for f in topic.fields}
            out[topic.topic] = (topic.schema, fields)
    return out


def plotted(layout: dict) -> list[str]:
    return [p["value"] for panel in layout["configById"].values() for p in panel.get("paths", [])]


def test_every_plotted_path_is_published_by_a_puma_job(published):
    layout = json.loads(LAYOUT.read_text())
    paths = plotted(layout)
    assert len(paths) > 40
    for path in paths:
        topic, field, index = PATH.match(path).groups()
        assert topic in published, path
        schema, fields = published[topic]
        assert field in schema["properties"] and field in fields, path
        length = fields[field]
        assert (index is None) == (length is None), path  # a vector is indexed, a scalar is not
        assert index is None or int(index) < length, path
    assert layout["configById"]["Log!events"]["topicToRender"] == EVENTS


def test_every_channel_of_the_computed_torque_and_cstar_jobs_is_shown(published):
    shown = {PATH.match(p).group(1) for p in plotted(json.loads(LAYOUT.read_text()))} | {EVENTS}
    for job in JOBS[:2]:
        shapes, meta = recorded_shapes(job)
        assert {t.topic for t in topics(shapes, meta)} <= shown, job


def test_the_shipped_file_is_the_scripts_output(tmp_path):
    ran = subprocess.run([sys.executable, str(ROOT / "scripts" / "foxglove_layout.py"), str(tmp_path / "out.json")],
                         capture_output=True, text=True, cwd=ROOT)
    assert ran.returncode == 0, ran.stderr
    assert (tmp_path / "out.json").read_bytes() == LAYOUT.read_bytes()
