"""``rtctl``: the command line. Every subcommand's ``--help`` says what it does.

Exit codes (documented for systemd units and scripts):
  0  clean exit (duration reached, ``stop``, SIGTERM or SIGINT) with no fault left latched
  1  unexpected internal error (a bug: please report the traceback)
  2  invalid configuration or command-line arguments (nothing was touched)
  3  safe stop after a fault (limit, watchdog, device error, overruns, e-stop, telemetry
     writer failure), or any run that ends with its fallback engaged and not cleared by
     ``reset``; ``move``/``reset`` refused by the daemon
  4  hardware could not be brought up (driver missing, link failed), or a device could
     not confirm its drives off at the end
  5  ``--enforce-rt`` and a real-time knob could not be applied
  6  the control socket could not be reached (status/stop/estop/reset/move/…), or ``run``
     found its control socket or telemetry file held by another running daemon
"""
from __future__ import annotations

import argparse
import math
import os
import sys

from rtctl.errors import EXIT_OK, RtctlError, exit_code_for


def _number(kind: str, ok):
    """An argparse type: a finite float for which ``ok`` holds (argparse exits 2 otherwise)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and ok(value)):
            raise argparse.ArgumentTypeError(f"expected {kind}, got {text!r}")
        return value

    parse.__name__ = kind  # argparse names the type in its messages
    return parse


_SECONDS = _number("a finite number of seconds > 0", lambda x: x > 0)
_FACTOR = _number("a finite number ≥ 0", lambda x: x >= 0)
_FINITE = _number("a finite number", lambda x: True)
_RATE = _number("a rate in Hz in [1, 100000]", lambda x: 1 <= x <= 1e5)


def _count(text: str) -> int:
    """An argparse type: an integer ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer ≥ 1, got {text!r}")
    return value


class _Version(argparse.Action):
    """``--version``: looked up only when asked (importlib.metadata costs 40 ms every command)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import PackageNotFoundError, version

        try:
            print(f"rtctl {version('rtctl')}")
        except PackageNotFoundError:  # (run from a source tree that is not installed)
            print("rtctl (version unknown: not installed)")
        parser.exit()


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="rtctl", description="Real-time control runtime for robot joints. Documentation: docs/index.md "
                                 "in the source tree.",
        epilog=__doc__.split("\n", 2)[2].replace("``", ""), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action=_Version, nargs=0, help="print rtctl's version and exit")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_parser = sub.add_parser

    def add_explained(name, **kwargs):  # every subcommand's own --help starts with what it does
        kwargs.setdefault("description", kwargs.get("help"))
        return add_parser(name, **kwargs)

    sub.add_parser = add_explained

    run = sub.add_parser("run", help="run the control loop in the foreground (the daemon)",
                         description="Run the fixed-rate control loop on the devices of CONFIG until "
                                     "the duration ends, `rtctl stop`, SIGTERM or SIGINT. Logs go to stdout: "
                                     "readable lines and a summary table on a terminal, one strict JSON object "
                                     "per line otherwise (systemd/journald) or with --log-format json.")
    run.add_argument("config", help="run configuration (TOML), e.g. configs/puma560_sim.toml")
    run.add_argument("--sim", action="store_true", help="replace the joint devices by the embedded simulator")
    run.add_argument("--cell", metavar="CELLFILE", help="enforce this cell's shared zones (leases; `rtctl cell up` "
                                                        "passes it)")
    run.add_argument("--cell-robot", metavar="NAME", help="which robot of --cell this run is")
    run.add_argument("--duration", type=_SECONDS, metavar="S", help="stop after S seconds of loop time (default: run until `rtctl stop`, SIGTERM or Ctrl-C)")
    run.add_argument("--realtime-factor", type=_FACTOR, metavar="F",
                     help="simulated devices only: 0 = as fast as possible (reproducible), 1 = wall clock")
    run.add_argument("--telemetry", metavar="PATH", help="record telemetry (msgpack) to PATH")
    run.add_argument("--live", nargs="?", const="", metavar="[HOST:]PORT",
                     help="serve the run live to Foxglove (ws://127.0.0.1:8765 unless given here or in [live]; "
                          "needs the `live` extra)")
    run.add_argument("--summary", metavar="PATH", help="write the JSON run summary to PATH at exit")
    run.add_argument("--socket", metavar="PATH", help="control socket path (default from config)")
    run.add_argument("--enforce-rt", action="store_true", help="refuse to start unless every real-time knob applies")
    run.add_argument("--log-level", default="info", choices=("debug", "info", "warning", "error"))
    run.add_argument("--log-format", default="auto", choices=("auto", "console", "json"),
                     help="auto (default): console on a terminal, json otherwise")
    run.add_argument("--progress", type=_FACTOR, metavar="S",
                     help="log a 'running' line (loop time, ticks, overruns, tracking error) every S s of wall "
                          "time; 0 = never (default: every second on a terminal, never in JSON logs)")

    check = sub.add_parser("check", help="validate a run configuration; print the bus-load budget, the environment "
                                         "variables a run reads and the guard's report (crossings of interference "
                                         "zones and the bypasses)")
    check.add_argument("config")
    check.add_argument("--sim", action="store_true", help="check as `run --sim` would")

    plan = sub.add_parser("plan", help="plan a path around the interference zones (and draw it)",
                          description="Plan a joint-space path from the start (the simulator's initial_q, or "
                                      "--from) to --to — or along CONFIG's trajectory — around the zones of CONFIG "
                                      "(robot file and [[guard.zones]]): the shortest path in a two-joint plane, a "
                                      "resolution-complete grid search otherwise. Prints the path; exit 2 when there "
                                      "is none, with the reason.")
    plan.add_argument("config", help="run configuration (TOML)")
    plan.add_argument("--to", type=float, nargs="+", metavar="Q",
                      help="target joint positions (default: the configuration's trajectory waypoints)")
    plan.add_argument("--from", dest="start", type=float, nargs="+", metavar="Q",
                      help="start joint positions (default: the simulator's initial_q)")
    plan.add_argument("--deg", action="store_true", help="positions in degrees (revolute joints)")
    plan.add_argument("--sim", action="store_true", help="read CONFIG as `run --sim` would")
    plan.add_argument("--plot", metavar="PNG", help="draw the zones and the path in each joint plane that has a zone")

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
    model.add_argument("--q", type=_FINITE, nargs="+", metavar="Q", help="configuration (rad/m; default home = 0)")

    for name, text in (("status", "print the running daemon's status"), ("stop", "stop the daemon cleanly"),
                       ("estop", "emergency stop of the robot: damping, then drives off; the daemon stays up "
                                 "(`reset` re-enables the drives, `stop` ends it)"),
                       ("reset", "clear latched faults whose cause is gone")):
        s = sub.add_parser(name, help=text)
        s.add_argument("--socket", metavar="PATH", help="control socket path (default: $XDG_RUNTIME_DIR/rtctl.sock, or /tmp/rtctl-UID.sock "
                                                            "without XDG_RUNTIME_DIR)")
    socket_help = "control socket path (default: as for `status`)"
    s = sub.add_parser("controllers", help="list the running daemon's controllers: type, joints, rate, active or not, "
                                           "and the parameters `set` may change")
    s.add_argument("--socket", metavar="PATH", help=socket_help)
    s = sub.add_parser("switch", help="activate controllers at the next tick, bumplessly; by default the ones "
                                      "now driving their joints stop",
                       description="Activate NAME… at one tick boundary. The controllers now driving the same joints "
                                   "are deactivated (or exactly those given with --off). Refused if a joint would be "
                                   "left without a controller or given two. The torque is blended from the old "
                                   "controller's last command to the new one's (time constant 50 ms).")
    s.add_argument("names", nargs="*", metavar="NAME", help="controllers to activate")
    s.add_argument("--off", nargs="+", metavar="NAME", help="controllers to deactivate (default: those whose joints "
                                                            "the activated ones take over)")
    s.add_argument("--keep-estimates", action="store_true", help="an adaptive controller resumes from what it had "
                                                                 "learnt (default: from its configured estimates)")
    s.add_argument("--socket", metavar="PATH", help=socket_help)
    s = sub.add_parser("get", help="read a live parameter: NAME.KEY (a controller's, or safety's)")
    s.add_argument("key", metavar="NAME.KEY", help="e.g. ct.kp or safety.damping (`rtctl controllers` lists them)")
    s.add_argument("--socket", metavar="PATH", help=socket_help)
    s = sub.add_parser("set", help="change a live parameter at the next tick, checked as in the configuration file",
                       description="VALUE is written as in the configuration file: a number (every joint) or an "
                                   "array, e.g. '[400, 400, 100]'. The change is applied at one tick boundary, logged "
                                   "and recorded in telemetry (column NAME.KEY). The robot model, the device layout "
                                   "and the rate cannot change while the daemon runs.")
    s.add_argument("key", metavar="NAME.KEY", help="e.g. ct.kp or safety.damping")
    s.add_argument("value", metavar="VALUE", help="a number or a TOML array of numbers")
    s.add_argument("--socket", metavar="PATH", help=socket_help)
    move = sub.add_parser("move", help="move to joint positions along a smooth trajectory")
    move.add_argument("q", type=_FINITE, nargs="+", help="target joint positions")
    move.add_argument("--deg", action="store_true", help="positions in degrees (revolute joints)")
    move.add_argument("--duration", type=_SECONDS, help="seconds (default: as fast as the limits allow)")
    move.add_argument("--socket", metavar="PATH")

    plot = sub.add_parser("plot", help="draw a telemetry file (needs the `plot` extra: matplotlib)")
    plot.add_argument("path")
    plot.add_argument("-o", "--output", required=True, help="PNG to write")

    export = sub.add_parser("export", help="convert a telemetry file (needs the `mcap` extra for --mcap)",
                            description="Write a recorded run as MCAP with JSON-schema channels (joint states, "
                                        "commands, controller internals, timing, events) for Foxglove or PlotJuggler.")
    export.add_argument("path", help="telemetry file written by `rtctl run` (msgpack)")
    export.add_argument("--mcap", required=True, metavar="OUT", help="MCAP file to write")
    ident = sub.add_parser("identify", help="fit the ARX model to a recorded run (adaptive Kalman filter)",
                           description="Run the Sage–Husa filter of the arma_gmv controller over a telemetry "
                                       "file (y = measured position q, u = commanded torque tau) and print, per "
                                       "joint, θ̂ = [a1 … a_na, b0 … b_nb], r̂, R̂ and the RMS one-step "
                                       "prediction error ε.")
    ident.add_argument("path", help="telemetry file (rtctl run --telemetry)")
    ident.add_argument("--joints", nargs="+", metavar="NAME", help="joint names (default: all; commas allowed)")
    ident.add_argument("--period", type=float, metavar="S", help="sample time in s (default: every recorded tick)")
    ident.add_argument("--na", type=int, default=2, help="output order (default 2)")
    ident.add_argument("--nb", type=int, default=2, help="input order: b0 … b_nb (default 2)")
    ident.add_argument("--d", type=int, default=1, help="dead time in samples (default 1)")
    ident.add_argument("--lam", type=float, default=0.98, help="forgetting factor λ of the noise statistics, in (0, 1)")
    ident.add_argument("--adapt", nargs="*", default=[], choices=("r", "R", "q", "Q"),
                       help="switched-on adaptations of the noise statistics (default: none — a least-squares "
                            "fit; adapting them from θ̂(0) = 0 on closed-loop data lets them absorb the model)")
    ident.add_argument("--p0", type=float, default=1e3, help="P(0) = p0·I, θ̂(0) = 0 (default 1e3)")
    ident.add_argument("--r0", type=float, default=1e-6, help="R̂(0) (default 1e-6)")
    ident.add_argument("--json", metavar="PATH", help="also write the result as JSON")

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
    bench.add_argument("what", choices=("dynamics", "loop", "loop-timing", "live", "can", "control", "telemetry",
                                        "control-socket", "safety", "trajectory", "leg", "soak", "guard", "grabber",
                                        "switching", "plants", "cell"),
                       help="dynamics: model algorithms vs Pinocchio; loop: the full stack on the embedded "
                            "PUMA 560; loop-timing: an empty loop (like cyclictest); live: the loop with and without "
                            "the Foxglove live view and one viewer, side by side; can: codec and transports; "
                            "control: the Slotine–Li laws and arma_gmv; telemetry, control-socket, safety, trajectory: their per-tick costs; "
                            "leg: the leg automaton's gates + circuit per tick and the leg board codec; "
                            "soak: the full stack over HIL (socketcand, MIT and CiA 402) for --minutes: RSS, GC, "
                            "overruns and lateness per minute, telemetry rows, drives left enabled; "
                            "guard: the per-tick interference guard (16 zones on 6 joints) and bypass planning "
                            "(against OMPL's RRT-Connect when the `bench` extra is installed); "
                            "grabber: framegrabber driver, unpacking, marker, camera simulator; "
                            "switching: the loop untouched, then with 10 controller switches or gain sets per second; "
                            "plants: one period of rtctl's plant and of MuJoCo's; "
                            "cell: cell-wide e-stop latency over Zenoh with 1, 2 and 4 robots, state messages per "
                            "second, the loops' cost (the `cell` extra)")
    bench.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    bench.add_argument("--robot", default=None, help="robot description (default: the shipped PUMA 560)")
    bench.add_argument("--config", default=None, help="run configuration for `bench loop`/`live` (default: the shipped one)")
    bench.add_argument("--rate", type=_RATE, default=1000.0, help="loop rate for `bench loop` (Hz)")
    bench.add_argument("--seconds", type=_SECONDS, default=10.0,
                       help="duration for `bench loop` and `bench switching` (s; `live`: per run)")
    bench.add_argument("--trials", type=_count, default=100, metavar="N",
                       help="`bench cell`: cell-wide e-stops per cell size (1, 2 and 4 robots; default 100)")
    bench.add_argument("--minutes", type=_SECONDS, default=10.0,
                       help="duration for `bench soak` (default 10; --config: another HIL configuration)")

    sub.add_parser("doctor", help="report this machine's real-time readiness and what to change")

    _add_cell_parser(sub)

    _add_leg_parser(sub)
    return p


def _add_cell_parser(sub) -> None:
    cell = sub.add_parser("cell", help="several robots as one cell over Zenoh: start, status, stop, e-stop, reset "
                                       "(needs the `cell` extra; docs/cell.md)")
    cellsub = cell.add_subparsers(dest="cell_command", required=True, metavar="ACTION")
    for name, text in (("up", "start every daemon of the cell and one Zenoh bridge per robot, show their status, "
                              "and stop them all on Ctrl-C or SIGTERM (or once every daemon has ended)"),
                       ("status", "every robot's status, through Zenoh"),
                       ("stop", "stop every robot's daemon cleanly"),
                       ("estop", "e-stop every robot of the cell: damping, then drives off; the daemons stay up"),
                       ("reset", "clear every robot's latched faults whose cause is gone")):
        p = cellsub.add_parser(name, help=text, description=text)
        p.add_argument("cellfile", help="cell file (TOML), e.g. configs/cell/two_puma_sim.toml")
        if name == "up":
            p.add_argument("--start-timeout", type=_SECONDS, default=300.0, metavar="S",
                           help="give up when a daemon does not answer within S seconds (a machine's first run "
                                "compiles the kernels; default 300)")
            p.add_argument("--robot", action="append", metavar="NAME",
                           help="start only this robot (repeatable; default: all): a cell on several hosts "
                                "starts each host's robots there")


LEG_TABLE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "configs", "leg", "table3.toml")


def _add_leg_parser(sub) -> None:
    """`rtctl leg` (defined here: importing rtctl.logic loads numba, which a parser must not)."""
    leg = sub.add_parser("leg", help="the prosthetic-leg automaton: event table → J-K/PLA circuit; replay",
                         description="Synthesise an event table (the leg paper's Table 3) into a race-free "
                                     "asynchronous J-K flip-flop circuit in a PLA, verify it exhaustively, "
                                     "and replay the table in every order of its bit changes.")
    legsub = leg.add_subparsers(dest="leg_command", required=True, metavar="ACTION")
    for name, text in (("compile", "flow table, guards, state assignment, equations, PLA matrix, checks"),
                       ("replay", "replay the table: every one-at-a-time order of the bits changing between rows")):
        p = legsub.add_parser(name, help=text, description=text)
        p.add_argument("table", nargs="?", default=str(LEG_TABLE),
                       help="event table (TOML; default: the shipped configs/leg/table3.toml)")
        p.add_argument("--semantics", choices=("exact", "guard"), default="exact",
                       help="exact (default): an exit fires only on the table's gate vector, every other "
                            "vector holds; guard: on its single gate event (what the shipped leg jobs run)")
        if name == "compile":
            p.add_argument("--pla", metavar="PATH", help="also write the PLA in Berkeley (espresso) .pla format")


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        return _dispatch(args)
    except RtctlError as e:
        code, prefix = exit_code_for(e)
        print(f"rtctl: {prefix}{e}", file=sys.stderr)
        return code
    except KeyboardInterrupt:
        return EXIT_OK
    except BrokenPipeError:  # `rtctl model … | head`: the reader left, nothing is wrong
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK


def _dispatch(args) -> int:
    if args.command == "run":
        import structlog

        from rtctl import logs  # light: the first line is out before the daemon's imports (numba …)

        fmt = logs.resolve_format(args.log_format)
        logs.configure(fmt, level=args.log_level)
        structlog.get_logger("rtctl.daemon").info("starting", config=str(args.config))
        from rtctl.daemon import run

        return run(args, fmt)
    if args.command == "check":
        from rtctl.commands import check

        return check(args)
    if args.command == "plan":
        from rtctl.guard.commands import plan

        return plan(args)
    if args.command == "margins":
        from rtctl.commands import margins

        return margins(args)
    if args.command == "model":
        from rtctl.commands import print_model

        return print_model(args)
    if args.command in ("status", "stop", "estop", "reset", "move", "controllers", "switch", "get", "set"):
        from rtctl.control_socket.command import control_request

        return control_request(args)
    if args.command == "plot":
        from rtctl.plot import plot_run

        print(plot_run(args.path, args.output))
        return EXIT_OK
    if args.command == "grab":
        from rtctl.vision.grab import grab

        return grab(args)
    if args.command == "export":
        from rtctl.telemetry.mcap_export import export_mcap

        counts = export_mcap(args.path, args.mcap)
        print(f"{args.mcap}: " + ", ".join(f"{topic} {n}" for topic, n in counts.items()))
        if counts.incomplete:
            print(f"note: {counts.incomplete}")
        return EXIT_OK
    if args.command == "identify":
        from rtctl.estimation.identify import main as identify

        return identify(args)
    if args.command == "bench":
        from rtctl.commands import bench

        return bench(args)
    if args.command == "leg":
        from rtctl.logic.cli import leg_command

        return leg_command(args)
    if args.command == "cell":
        from rtctl.cell.commands import cell_command

        return cell_command(args)
    if args.command == "doctor":
        from rtctl.commands import doctor

        return doctor(args)
    raise AssertionError(args.command)


if __name__ == "__main__":
    sys.exit(main())
