"""What a daemon's run leaves behind: its telemetry columns and its summary (docs/operations.md).

Split from :mod:`rtctl.daemon`, whose loop owns the arrays these read; each function takes the
running :class:`~rtctl.daemon.Daemon`.
"""
from __future__ import annotations

from pathlib import Path

import structlog

from rtctl import jsonout
from rtctl.errors import ConfigError, TelemetryError
from rtctl.timing import DAEMON_PHASES

log = structlog.get_logger("rtctl.daemon")


def open_recorder(daemon, path: Path):
    """The run's telemetry: every state and command array, the phase times, each controller's
    internals and live parameters (and the shared zones' columns in a cell), bound to a Recorder
    whose writer process stores them in ``path``; the tick records into it."""
    from rtctl.telemetry import Recorder

    n = daemon.model.nq
    rt = daemon.rt
    schema = {"t": ((), "f8"), "q": (n, "f8"), "qd": (n, "f8"), "q_des": (n, "f8"), "qd_des": (n, "f8"),
              "tau": (n, "f8"), "phase_ns": (len(DAEMON_PHASES), "i8")}
    sources = {"q": rt.state.position, "qd": rt.state.velocity, "q_des": rt.ref.q, "qd_des": rt.ref.qd,
               "tau": rt.command.tau_ff, "phase_ns": daemon.ticker.phase_ns}
    for c in rt.configured:
        for name, arr in c.internals.items():
            col = name if name not in schema else f"{c.name}.{name}"
            schema[col] = (arr.shape, arr.dtype.str)
            sources[col] = arr
    extra = {} if daemon.zones is None else daemon.zones.telemetry_columns()
    for col, arr in (daemon.live.telemetry_columns() | extra).items():
        schema[col] = (arr.shape, arr.dtype.str)
        sources[col] = arr
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        where = ("<command line>", "--telemetry") if daemon.args.telemetry else (daemon.cfg.file, "telemetry.path")
        raise ConfigError(*where, f"a file in a directory that exists or can be created; "
                                  f"{path.parent}: {e.strerror or e}") from None
    meta = {"config": str(daemon.cfg.file), "robot": daemon.model.name, "joints": list(daemon.model.joint_names),
            "rate_hz": daemon.cfg.loop.rate_hz, "phases": list(DAEMON_PHASES),
            "controllers": [c.name for c in rt.configured], "tunables": list(daemon.live.tunables)}
    for c in rt.configured:  # e.g. the names of a vector column's entries: "leg_gates_labels"
        meta.update(getattr(c, "telemetry_meta", {}))
    rec = Recorder(path, schema, meta, block_rows=daemon.cfg.telemetry_batch,
                   wait_when_full=daemon.cfg.loop.realtime_factor == 0)
    for name, arr in sources.items():
        rec.bind(name, arr)
    daemon.tick.recorder = rec
    return rec


def finish(daemon) -> None:
    """The run's summary: into the telemetry file's footer, the live view, ``--summary`` and, when
    asked, one log line."""
    summary = {"config": str(daemon.cfg.file), "robot": daemon.model.name, "exit_code": daemon.exit_code,
               "stop_reason": daemon.stop_reason, "timing": daemon.ticker.summary(),
               "tracking_error_rad": daemon.tick.tracking_summary(), "safety": daemon.safety.summary(),
               "operator": {"events": daemon.live.events},
               # tick k began at tick0 + k·period/realtime_factor on CLOCK_MONOTONIC: another
               # process on this machine can place the safety events' ticks on its own clock
               "clock": {"tick0_monotonic_ns": daemon.ticker.deadline_ns(0) if daemon.cfg.loop.realtime_factor else None},
               "devices": {d.name: d.diagnostics() for d in daemon.rt.all_devices}}
    if daemon.recorder is not None:
        summary["telemetry"] = {"path": str(daemon.recorder.path), "rows": daemon.recorder.rows,
                                "dropped_rows": daemon.recorder.dropped_rows, "error": daemon.telemetry_failure}
        try:
            daemon.recorder.close(summary=summary)
        except TelemetryError as e:  # the summary is written all the same
            if daemon.telemetry_failure is None:  # (else reported when it happened)
                log.error("telemetry failed", reason=str(e))
            summary["telemetry"]["error"] = str(e)
    if daemon.live_view is not None:
        daemon.live_view.close(summary)
    daemon.summary = summary
    if daemon.args.summary:
        try:
            Path(daemon.args.summary).parent.mkdir(parents=True, exist_ok=True)
            Path(daemon.args.summary).write_text(jsonout.dumps(summary, indent=2))
        except OSError as e:
            log.error("summary not written", path=str(daemon.args.summary), reason=e.strerror or str(e))
    if not daemon.summary_line:
        return
    timing = summary["timing"]
    log.info("summary", exit_code=daemon.exit_code, stop_reason=daemon.stop_reason, ticks=timing.get("ticks"),
             overruns=timing.get("overruns"), achieved_rate_hz=timing.get("achieved_rate_hz"),
             realtime_ratio=timing.get("realtime_ratio"),
             lateness_p99_us=(timing.get("wake_lateness_us") or {}).get("p99"),
             compute_p99_us=(timing.get("compute_us") or {}).get("tick", {}).get("p99"),
             **({} if not daemon.tick.tracks else {
                 "tracking_rms_rad": summary["tracking_error_rad"]["rms_all"],
                 "tracking_max_rad": summary["tracking_error_rad"]["max_all"]}),
             faults=len(summary["safety"]["faults"]))
