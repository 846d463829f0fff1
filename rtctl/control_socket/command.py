"""``rtctl status|stop|estop|reset|move``: one request to the daemon, its reply printed as JSON.

Light on purpose: an operator's ``estop`` must not wait for numpy or numba to import (it took
1.3–2.5 s when it did); this path imports the standard library, msgpack and the client only.
"""
from __future__ import annotations

from rtctl.control_socket.client import default_socket_path, request
from rtctl.errors import EXIT_CONFIG, EXIT_FAULT as EXIT_REFUSED, EXIT_OK
from rtctl.jsonout import print_json


def control_request(args) -> int:
    path = args.socket or default_socket_path()
    fields = {}
    if args.command == "move":
        fields = {"q": list(args.q), "deg": args.deg}
        if args.duration is not None:
            fields["duration"] = args.duration
    # a move is answered once it is planned and has started: planning may take seconds
    reply = request(path, args.command, timeout=120.0 if args.command == "move" else 5.0, **fields)
    print_json(reply)
    if reply.get("invalid"):  # the request itself was wrong (e.g. the number of joints)
        return EXIT_CONFIG
    return EXIT_OK if reply.get("ok", False) else EXIT_REFUSED
