"""The short subcommands of ``rtctl`` (the daemon lives in :mod:`rtctl.daemon`)."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from rtctl import jsonout
from rtctl.errors import EXIT_OK

SHIPPED_PUMA = Path(__file__).resolve().parent.parent / "configs" / "robots" / "puma560.toml"


def print_model(args) -> int:
    from rtctl.model import dynamics, kinematics, load_robot

    from rtctl.guard.config import load_guard

    model = load_robot(args.robot)
    guard = load_guard(None, Path(args.robot), model)  # the file's interference zones, checked as a run would
    q = np.zeros(model.nq) if args.q is None else np.array(args.q, dtype=float)
    if q.shape != (model.nq,):
        from rtctl.errors import ConfigError

        raise ConfigError("<command line>", "--q", f"{model.nq} joint values, got {q.size}")
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    print(f"robot {model.name}: {model.nq} joints" + (f"  (reconstructed: {model.reconstructed})" if model.reconstructed else ""))
    for i, name in enumerate(model.joint_names):
        kind = "revolute" if model.joint_types[i] == 0 else "prismatic"
        print(f"  {i + 1}. {name:<12} {kind:<9} limits [{model.q_min[i]:+.3f}, {model.q_max[i]:+.3f}]  "
              f"mass {model.params[i, 0]:.3f} kg")
    if guard is not None:
        print(f"interference zones ({np.degrees(guard.scene.margin):.3g}° margin): "
              + ", ".join(z.name for z in guard.scene.zones))
    print(f"q = {q}")
    print("tool pose F = ⁰Tₙ · tool:")
    print(kinematics.fk(model, q))
    print("mass matrix H(q):")
    print(dynamics.mass_matrix(model, q))
    print(f"gravity G(q) = {dynamics.gravity(model, q)}")
    timings = {}
    for name, fn in (("rnea", lambda: dynamics.rnea(model, q, q, q)),
                     ("mass_matrix", lambda: dynamics.mass_matrix(model, q))):
        fn()
        t0 = time.perf_counter()
        for _ in range(1000):
            fn()
        timings[name] = (time.perf_counter() - t0) * 1e3
    print("timing: " + ", ".join(f"{k} {v:.1f} µs/call" for k, v in timings.items()))
    return EXIT_OK


def margins(args) -> int:
    """The delay margins of every adaptive (Slotine–Li) controller of a configuration."""
    from rtctl.config import load_config
    from rtctl.control.margins import format_margins, trajectory_margins
    from rtctl.trajectory import JointLimits
    from rtctl.errors import ConfigError
    from rtctl.runtime import build
    from rtctl.trajectory import through_waypoints

    cfg = load_config(args.config)
    adaptive = [(c, spec) for c, spec in zip(build(cfg).controllers, cfg.controllers) if hasattr(c, "gamma")]
    if not adaptive:
        raise ConfigError(cfg.file, "controllers", "a slotine_li controller to analyse")
    if cfg.trajectory is None:
        raise ConfigError(cfg.file, "trajectory", "a trajectory: the margins are taken along it")
    trajectory = through_waypoints(cfg.trajectory.waypoints, JointLimits.for_run(cfg.model, cfg.trajectory), smooth=cfg.trajectory.smooth)
    for rate in args.rate or [cfg.loop.rate_hz]:
        if not (rate > 0 and np.isfinite(rate)):
            raise ConfigError("<command line>", "--rate", f"a positive rate in Hz, got {rate}")
        for c, spec in adaptive:
            m = trajectory_margins(cfg.model, c, trajectory, rate / spec.divisor, motor_model=c.motor_model)
            print(format_margins(c.name, rate / spec.divisor, m))
    return EXIT_OK


def check(args) -> int:
    """Validate everything `run` would, without touching a device; print the bus budget and
    the environment variables the run will need (an unset one is reported, not an error)."""
    from rtctl.daemon import prepare
    from rtctl.tomltable import deferred_env

    with deferred_env() as env_uses:
        daemon = prepare(args)  # what `run` does before it opens anything: load, build, plan
    cfg, runtime = daemon.cfg, daemon.rt
    from rtctl.guard.commands import check_lines
    from rtctl.trajectory import JointLimits

    # everything is checked before "OK" is printed: a guard leg without a path is exit 2 with no OK above it
    details = [*runtime.bus_budget(), *_env_lines(env_uses),
               *check_lines(cfg, JointLimits.for_run(cfg.model, cfg.trajectory))]
    print(f"{cfg.file}: OK — robot {cfg.model.name} ({cfg.model.nq} joints), "
          f"{cfg.loop.rate_hz:g} Hz, devices: {', '.join(f'{d.name} ({d.driver})' for d in cfg.devices)}, "
          f"controllers: {', '.join(f'{c.name} ({c.type})' for c in cfg.controllers) or 'none'}")
    for line in details:
        print(line)
    return EXIT_OK


def _env_lines(uses) -> list[str]:
    """What `check` says about the ``${VAR}`` a configuration names."""
    if not uses:
        return []
    lines = ["environment variables the run reads:"]
    for use in uses:
        if use.value is not None:
            state = f"set: {use.value!r}"
        elif use.default is not None:
            state = f"not set: the default {use.default!r} applies"
        else:
            state = "NOT SET: `run` needs it (it was not checked here)"
        lines.append(f"  {use.name:<16} {use.key} — {state}")
    return lines


def bench(args) -> int:
    robot = args.robot or str(SHIPPED_PUMA)
    if args.what == "dynamics":
        from rtctl.bench.dynamics import bench_dynamics as run, format_table

        result = run(robot)
    elif args.what == "loop":
        from rtctl.bench.loop import bench_loop as run, format_table

        result = run(args.config, rate=args.rate, seconds=args.seconds)
    elif args.what == "live":
        from rtctl.bench.live import bench_live as run, format_table

        result = run(args.config, rate=args.rate, seconds=args.seconds)
    elif args.what == "telemetry":
        from rtctl.bench.telemetry import bench_telemetry as run, format_table

        result = run(rate=args.rate)
    elif args.what == "control-socket":
        from rtctl.bench.control_socket import bench_control_socket as run, format_table

        result = run()
    elif args.what == "grabber":
        from rtctl.bench.grabber import bench_grabber as run, format_table

        result = run()
    elif args.what in ("safety", "trajectory", "leg", "guard"):
        from importlib import import_module

        module = import_module(f"rtctl.bench.{args.what}")
        result, format_table = getattr(module, f"bench_{args.what}")(), module.format_table
    elif args.what == "loop-timing":
        from rtctl.bench.loop_timing import bench_loop_timing as run, format_table

        result = run(args.rate, args.seconds)
    elif args.what == "can":
        from rtctl.bench.can import bench_can as run, format_table

        result = run()
    elif args.what == "plants":
        from rtctl.bench.plants import bench_plants as run, format_table

        result = run(robot)
    elif args.what == "cell":
        from rtctl.bench.cell import bench_cell as run, format_table

        result = run(args.config, trials=args.trials)
    elif args.what == "switching":
        from rtctl.bench.switching import bench_switching as run, format_table

        result = run(args.seconds)
    elif args.what == "soak":
        from rtctl.bench.soak import bench_soak as run, format_table

        result = run(args.config, minutes=args.minutes)
    else:
        from rtctl.bench.control import bench_control as run, format_table

        result = run(robot)
    print(format_table(result))
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(jsonout.dumps(result, indent=2))
        print(f"wrote {args.json}")
    return EXIT_OK


def doctor(args) -> int:
    from rtctl.timing.doctor import doctor as run_doctor, format_doctor

    print(format_doctor(run_doctor()))
    return EXIT_OK
