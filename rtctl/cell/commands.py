"""``rtctl cell up|status|stop|estop|reset CELLFILE`` (docs/cell.md).

The commands other than ``up`` speak only Zenoh: one query on
``rtctl/<cell>/*/cmd/<name>`` reaches every robot's bridge at once, each forwards it to its
daemon's control socket and answers with the daemon's reply.
"""
from __future__ import annotations

import json
import signal
import sys
import time

from rtctl.cell.config import NAME, load_cell
from rtctl.cell.session import open_client_session, raise_priority, zenoh_module
from rtctl.errors import EXIT_FAULT, EXIT_OK, EXIT_SOCKET, ConfigError, RtctlError

QUERY_TIMEOUT_S = 3.0
BRIDGES_UP_S = 15.0


def query_all(cell, session, name: str, fields: dict | None = None, timeout_s: float = QUERY_TIMEOUT_S) -> dict:
    """{robot: the daemon's reply (a dict with "ok")} for command ``name``, sent to every robot
    in one query; a robot that did not answer within ``timeout_s`` maps to ok False."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise ValueError(f"name: expected a command name (one Zenoh key chunk), got {name!r}")
    if fields is not None and not isinstance(fields, dict):
        raise ValueError(f"fields: expected a dict of the command's fields, got {type(fields).__name__}")
    if not timeout_s > 0:
        raise ValueError(f"timeout_s: expected > 0, got {timeout_s!r}")
    zenoh = zenoh_module()
    replies = session.get(cell.key("*", "cmd", name), target=zenoh.QueryTarget.ALL,
                          consolidation=zenoh.ConsolidationMode.NONE, timeout=timeout_s,
                          payload=json.dumps(fields) if fields else None)
    out = {}
    for reply in replies:
        if reply.ok is None:
            continue  # (a bridge always answers with ok; an error reply is Zenoh's own)
        robot = str(reply.ok.key_expr).split("/")[2]
        try:
            out[robot] = json.loads(reply.ok.payload.to_bytes())
        except ValueError as e:
            out[robot] = {"ok": False, "error": f"garbled reply: {e}"}
    missing = {"ok": False, "error": f"no reply within {timeout_s:g} s (bridge not reachable, or credentials refused)"}
    return {r.name: out.get(r.name, missing) for r in cell.robots}  # (in the cell file's order)


def format_replies(name: str, replies: dict) -> str:
    rows = [("robot", "ok", "t (s)", "verdict", "e-stop", "shared zones", "faults / error")]
    for robot, r in replies.items():
        detail = r.get("error") or "; ".join(r.get("faults") or []) or "-"
        t = r.get("t")
        zones = r.get("zones") if isinstance(r.get("zones"), dict) else {}
        shared = ", ".join(f"{name} " + ("held" if z.get("held") else "waiting" if z.get("waiting") else "-")
                           for name, z in zones.items() if isinstance(z, dict)) or "-"
        rows.append((robot, "yes" if r.get("ok") else "NO", "-" if t is None else f"{t:.3f}",
                     str(r.get("verdict", "-")), {True: "yes", False: "no"}.get(r.get("estopped"), "-"), shared,
                     detail))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]) - 1)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row[:-1], widths)) + "  " + row[-1] for row in rows]
    return f"cell {name}:\n" + "\n".join(lines)


def cell_command(args) -> int:
    if args.cell_command == "up":
        return cell_up(args)
    cell = load_cell(args.cellfile, check_robots=False)
    raise_priority(cell)  # (best effort: a command line without the privilege is only slower on a busy machine)
    session, _ = open_client_session(cell)
    try:
        replies = query_all(cell, session, args.cell_command)
    finally:
        session.close()
    print(format_replies(cell.name, replies))
    if not all("robot" in r for r in replies.values()):
        return EXIT_SOCKET
    return EXIT_OK if all(r["ok"] for r in replies.values()) else EXIT_FAULT


def _first_status(cell, procs, stop: list, timeout_s: float = BRIDGES_UP_S) -> dict:
    """Every robot's status through Zenoh, asked until the bridges ``procs`` started have
    answered — they open their sessions while this one connects — or ``timeout_s``; a
    bridge that ends meanwhile is an error."""
    robots = [m.robot for m in procs.members]
    session, _ = open_client_session(cell, robots, wait_s=timeout_s,
                                     give_up=lambda: bool(stop) or procs.lost_bridge() is not None)
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            replies = query_all(cell, session, "status", timeout_s=1.0)
            if procs.lost_bridge() is not None:
                raise RtctlError(f"cell {cell.name}: {procs.lost_bridge()}")
            if all("robot" in replies[r.name] for r in robots) or stop or time.monotonic() > deadline:
                return replies
    finally:
        session.close()


def _robots(cell, names) -> tuple:
    """The robots ``--robot`` names (all of them without it), or exit 2 for a name the cell lacks."""
    if not names:
        return cell.robots
    known = [r.name for r in cell.robots]
    for name in names:
        if name not in known:
            raise ConfigError("<command line>", "--robot", f"a robot of cell {cell.name!r} ({', '.join(known)}), "
                                                          f"got {name!r}")
    return tuple(r for r in cell.robots if r.name in names)


def cell_up(args) -> int:
    from rtctl.cell.supervisor import CellProcesses

    cell = load_cell(args.cellfile)
    robots = _robots(cell, args.robot)
    zenoh_module()  # (exit before anything starts if Zenoh is missing)
    stop = []
    previous = {s: signal.signal(s, lambda signum, _: stop.append(signum)) for s in (signal.SIGINT, signal.SIGTERM)}
    procs = CellProcesses(cell, robots)
    lost = None
    try:
        procs.start(args.start_timeout, stop_requested=lambda: bool(stop))
        if not stop:
            print(format_replies(cell.name, _first_status(cell, procs, stop)), flush=True)
            print("running; Ctrl-C or SIGTERM stops every robot of the cell", flush=True)
            lost = procs.watch(lambda: bool(stop))
            if lost is not None:
                print(f"rtctl: cell {cell.name}: {lost}; stopping every robot", file=sys.stderr, flush=True)
    finally:
        code = procs.stop()
        for s, h in previous.items():
            signal.signal(s, h)
    return code or (EXIT_FAULT if lost is not None else EXIT_OK)
