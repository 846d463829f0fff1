"""``rtctl``: the command line. Every subcommand's ``--help`` says what it does.

Exit codes (documented for systemd units and scripts):
  0  clean exit (duration reached, ``stop``, SIGTERM or SIGINT)
  1  unexpected internal error (a bug: please report the traceback)
  2  invalid configuration or command-line arguments (nothing was touched)
  3  safe stop after a fault (limit, watchdog, device error, overruns, e-stop)
  4  hardware could not be brought up (driver missing, link failed)
  5  ``--enforce-rt`` and a real-time knob could not be applied
  6  the control socket could not be reached (status/stop/estop/reset/move)
"""
from __future__ import annotations

import argparse
import json
import sys

from rtctl.errors import (ConfigError, ControlSocketError, HardwareError, RealtimeError, RtctlError,
                          SafetyError)

EXIT_OK, EXIT_BUG, EXIT_CONFIG, EXIT_FAULT, EXIT_HARDWARE, EXIT_RT, EXIT_SOCKET = range(7)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rtctl", description="Real-time control runtime for robot joints.",
        epilog=__doc__.split("\n", 2)[2], formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="run the control loop in the foreground (the daemon)",
                         description="Run the fixed-rate control loop on the devices of CONFIG until "
                                     "the duration ends, `rtctl stop`, SIGTERM or SIGINT. JSON logs on stdout.")
    run.add_argument("config", help="run configuration (TOML), e.g. configs/puma560_sim.toml")
    run.add_argument("--sim", action="store_true", help="replace the joint devices by the embedded simulator")
    run.add_argument("--duration", type=float, metavar="S", help="stop after S seconds of loop time")
    run.add_argument("--realtime-factor", type=float, metavar="F",
                     help="simulated devices only: 0 = as fast as possible (reproducible), 1 = wall clock")
    run.add_argument("--telemetry", metavar="PATH", help="record telemetry (msgpack) to PATH")
    run.add_argument("--summary", metavar="PATH", help="write the JSON run summary to PATH at exit")
    run.add_argument("--socket", metavar="PATH", help="control socket path (default from config)")
    run.add_argument("--enforce-rt", action="store_true", help="refuse to start unless every real-time knob applies")
    run.add_argument("--log-level", default="info", choices=("debug", "info", "warning", "error"))

    check = sub.add_parser("check", help="validate a run configuration and print the bus-load budget")
    check.add_argument("config")
    check.add_argument("--sim", action="store_true", help="check as `run --sim` would")

    margins = sub.add_parser(
        "margins", help="stability margins of the adaptive controllers against the wire's delay",
        description="For each Slotine–Li controller of CONFIG: the spectral radius of its sampled closed loop "
                    "and how far P and K_D may grow (or K_D shrink) before it loses stability, at the worst "
                    "point of the configured trajectory, with the measurement 0, 1 and 2 periods old (over a "
                    "CAN wire a drive's reply is one period old, two when it misses its deadline). "
                    "See docs/cstar_delay.md.")
    margins.add_argument("config")
    margins.add_argument("--rate", type=float, nargs="+", metavar="HZ",
                         help="loop rates to analyse (default: the configuration's)")

    model = sub.add_parser("model", help="print a robot: joints, tool pose, H, G and a timing line")
    model.add_argument("robot", help="robot description: D-H TOML or URDF")
    model.add_argument("--q", type=float, nargs="+", metavar="Q", help="configuration (rad/m; default home = 0)")

    for name, text in (("status", "print the running daemon's status"), ("stop", "stop the daemon cleanly"),
                       ("estop", "emergency stop: controlled stop, then drives off"),
                       ("reset", "clear latched faults whose cause is gone")):
        s = sub.add_parser(name, help=text)
        s.add_argument("--socket", metavar="PATH", help="control socket path (default: $XDG_RUNTIME_DIR/rtctl.sock)")
    move = sub.add_parser("move", help="move to joint positions along a smooth trajectory")
    move.add_argument("q", type=float, nargs="+", help="target joint positions")
    move.add_argument("--deg", action="store_true", help="positions in degrees (revolute joints)")
    move.add_argument("--duration", type=float, help="seconds (default: as fast as the limits allow)")
    move.add_argument("--socket", metavar="PATH")

    plot = sub.add_parser("plot", help="draw a telemetry file (needs the `plot` extra: matplotlib)")
    plot.add_argument("path")
    plot.add_argument("-o", "--output", required=True, help="PNG to write")

    grab = sub.add_parser("grab", help="save one image of a framegrabber device as a PNG (needs the `vision` extra)",
                          description="Bring up only the framegrabber device of CONFIG (no drive is touched), wait "
                                      "for one image and save it: grey levels stretched to 0-255, a field "
                                      "line-doubled. A simulated device runs in lock-step with the robot at rest.")
    grab.add_argument("config", help="run configuration with a [[devices]] of kind \"framegrabber\"")
    grab.add_argument("-o", "--output", required=True, help="PNG to write")
    grab.add_argument("--device", help="which framegrabber device (default: the first)")
    grab.add_argument("--sim", action="store_true", help="play the devices with the embedded simulator")
    grab.add_argument("--timeout", type=float, default=2.0, metavar="S", help="give up after S seconds (default 2)")

    bench = sub.add_parser("bench", help="measure performance on this machine (prints a table, writes JSON)")
    bench.add_argument("what", choices=("dynamics", "loop", "loop-timing", "can", "control", "telemetry",
                                        "control-socket", "safety", "trajectory", "grabber"),
                       help="dynamics: model algorithms vs Pinocchio; loop: the full stack on the embedded "
                            "PUMA 560; loop-timing: an empty loop (like cyclictest); can: codec and transports; "
                            "control: the Slotine–Li laws; telemetry, control-socket, safety, trajectory: their per-tick costs; "
                            "grabber: framegrabber driver, unpacking, marker, camera simulator")
    bench.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    bench.add_argument("--robot", default=None, help="robot description (default: the shipped PUMA 560)")
    bench.add_argument("--config", default=None, help="run configuration for `bench loop` (default: the shipped one)")
    bench.add_argument("--rate", type=float, default=1000.0, help="loop rate for `bench loop` (Hz)")
    bench.add_argument("--seconds", type=float, default=10.0, help="duration for `bench loop` (s)")

    sub.add_parser("doctor", help="report this machine's real-time readiness and what to change")
    return p


# Most specific first: each family of the error tree, its exit code and how the message starts.
_EXIT_FOR = (
    (ConfigError, EXIT_CONFIG, "configuration error: "),
    (RealtimeError, EXIT_RT, "real-time: "),
    (HardwareError, EXIT_HARDWARE, "hardware: "),
    (ControlSocketError, EXIT_SOCKET, ""),
    (SafetyError, EXIT_FAULT, "safe stop: "),
    (RtctlError, EXIT_CONFIG, ""),
)


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        return _dispatch(args)
    except RtctlError as e:
        code, prefix = next((c, p) for cls, c, p in _EXIT_FOR if isinstance(e, cls))
        print(f"rtctl: {prefix}{e}", file=sys.stderr)
        return code
    except KeyboardInterrupt:
        return EXIT_OK


def _dispatch(args) -> int:
    if args.command == "run":
        from rtctl.daemon import run

        return run(args)
    if args.command == "check":
        from rtctl.commands import check

        return check(args)
    if args.command == "margins":
        from rtctl.commands import margins

        return margins(args)
    if args.command == "model":
        from rtctl.commands import print_model

        return print_model(args)
    if args.command in ("status", "stop", "estop", "reset", "move"):
        from rtctl.commands import control_request

        return control_request(args)
    if args.command == "plot":
        from rtctl.plot import plot_run

        plot_run(args.path, args.output)
        print(args.output)
        return EXIT_OK
    if args.command == "grab":
        from rtctl.vision.grab import grab

        return grab(args)
    if args.command == "bench":
        from rtctl.commands import bench

        return bench(args)
    if args.command == "doctor":
        from rtctl.commands import doctor

        return doctor(args)
    raise AssertionError(args.command)


def print_json(obj) -> None:
    print(json.dumps(obj, indent=2, sort_keys=True, default=float))


if __name__ == "__main__":
    sys.exit(main())
