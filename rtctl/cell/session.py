"""Zenoh sessions for the cell, configured here in full (docs/cell.md, "The network"):

* peer mode; every listen endpoint is ``tcp/<host>:<port>`` with the cell's host
  (127.0.0.1 unless the cell file says otherwise) — never Zenoh's default ``tcp/[::]:0``,
  which listens on every interface;
* multicast scouting off (Zenoh's default is on): a peer learns of another only through the
  endpoints written in the cell file;
* Zenoh's user/password authentication on every link: a bridge holds the dictionary and
  refuses a session whose user and password are not in it — its link is never opened, so
  it can neither query a command nor subscribe to the state;
* Zenoh's access control on every bridge, by user name: the cell's user may command and
  observe, an ``observers`` user may only subscribe to the cell's keys, anyone else in the
  dictionary nothing (the default is deny).
"""
from __future__ import annotations

import json
import os

from rtctl.errors import RtctlError

MISSING = "the cell needs Zenoh: pip install 'rtctl[cell]' (eclipse-zenoh)"


def raise_priority(cell) -> str | None:
    """Put this process at the cell's ``bridge_priority`` (SCHED_FIFO) before it opens its Zenoh
    session, whose threads inherit it: the e-stop's path must not wait for a core behind the
    machine's other work. Returns why it could not (it then runs on at the ordinary priority)."""
    if not cell.bridge_priority:
        return None
    from rtctl.timing.rt import KnobStatus, RtSettings, apply_rt

    report = next(r for r in apply_rt(RtSettings(priority=cell.bridge_priority)) if r.knob == "sched_fifo")
    if report.status is KnobStatus.APPLIED:
        for tid in os.listdir("/proc/self/task"):  # and the threads started before (numpy's BLAS pool)
            try:
                os.sched_setscheduler(int(tid), os.SCHED_FIFO, os.sched_param(cell.bridge_priority))
            except (ProcessLookupError, PermissionError):  # (a thread that ended meanwhile)
                pass
        return None
    return f"SCHED_FIFO {cell.bridge_priority} not applied ({report.detail}): it runs at the ordinary priority"


def zenoh_module():
    try:
        import zenoh
    except ImportError:
        raise RtctlError(MISSING) from None
    return zenoh


def session_config(cell, *, listen: tuple = (), connect: tuple = (), user: str | None = None,
                   password: str | None = None, verify: bool = False):
    """A ``zenoh.Config``: peer mode, scouting as the cell says (off by default), exactly
    these endpoints (plus the cell's ``connect``), and usrpwd credentials / the dictionary
    that checks others' (``verify``)."""
    zenoh = zenoh_module()
    c = zenoh.Config()
    c.insert_json5("mode", '"peer"')
    c.insert_json5("scouting/multicast/enabled", json.dumps(cell.zenoh.multicast_scouting))
    c.insert_json5("listen/endpoints", json.dumps(list(listen)))
    c.insert_json5("connect/endpoints", json.dumps([*connect, *cell.zenoh.connect]))
    if user is not None:
        c.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
        c.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
    if verify:
        c.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(str(cell.auth.dictionary_file)))
        c.insert_json5("access_control", json.dumps(access_control(cell)))
    return c


def access_control(cell) -> dict:
    """A bridge's ACL. A rule's key expression must include the one a message carries: the
    commands' ``rtctl/<cell>/*/cmd/<name>`` and the subscriptions' ``rtctl/<cell>/*/state``."""
    everything, commands = f"rtctl/{cell.name}/**", f"rtctl/{cell.name}/*/cmd/**"
    both = ["ingress", "egress"]
    subjects = [{"id": "cell", "usernames": [cell.auth.user]}]
    policies = [{"rules": ["observe", "command"], "subjects": ["cell"]}]
    if cell.auth.observers:
        subjects.append({"id": "observers", "usernames": list(cell.auth.observers)})
        policies.append({"rules": ["observe"], "subjects": ["observers"]})
    return {"enabled": True, "default_permission": "deny",
            "rules": [{"id": "observe", "permission": "allow", "flows": both,
                       "messages": ["put", "declare_subscriber"], "key_exprs": [everything]},
                      {"id": "command", "permission": "allow", "flows": both,
                       "messages": ["query", "declare_queryable", "reply"], "key_exprs": [commands]}],
            "subjects": subjects, "policies": policies}


def open_bridge_session(cell, robot):
    """The bridge's session: listens on the robot's endpoint, checks every peer's credentials."""
    zenoh = zenoh_module()
    return zenoh.open(session_config(cell, listen=(robot.endpoint(),), user=cell.auth.user,
                                     password=cell.auth.password(), verify=True))


def open_client_session(cell, robots=None, *, credentials="cell", wait_s: float = 2.0, give_up=lambda: False):
    """A session that connects to the bridges of ``robots`` (default: all) — or, when the cell
    connects to a router (``[zenoh] connect``), to the router only; it listens nowhere.
    ``credentials``: "cell" (the cell's user and its password from the dictionary), a
    (user, password) pair, or None (none: every bridge refuses the link). Returns (session,
    the number of bridges — or routers — connected within ``wait_s``, or once ``give_up()``)."""
    import time

    zenoh = zenoh_module()
    robots = cell.robots if robots is None else robots
    user = password = None
    if credentials == "cell":
        user, password = cell.auth.user, cell.auth.password()
    elif credentials is not None:
        user, password = credentials
    routed = bool(cell.zenoh.connect)
    session = zenoh.open(session_config(cell, connect=() if routed else tuple(r.endpoint() for r in robots),
                                        user=user, password=password))
    wanted = 1 if routed else len(robots)
    deadline = time.monotonic() + wait_s
    while True:
        linked = len(list(session.info.routers_zid() if routed else session.info.peers_zid()))
        if linked >= wanted or time.monotonic() >= deadline or give_up():
            return session, linked
        time.sleep(0.01)
