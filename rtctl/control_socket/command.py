"""``rtctl status|stop|estop|reset|move|controllers|switch|get|set``: one request to the daemon, its reply printed as JSON.

Light on purpose: an operator's ``estop`` must not wait for numpy or numba to import (it took
1.3–2.5 s when it did); this path imports the standard library, msgpack and the client only.
"""
from __future__ import annotations

import sys
import tomllib

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
    elif args.command == "switch":
        fields = {"activate": args.names, "estimates": "keep" if args.keep_estimates else "initial"}
        if args.off:
            fields["deactivate"] = args.off
    elif args.command in ("get", "set"):
        fields = {"key": args.key}
        if args.command == "set":
            try:
                fields["value"] = tomllib.loads(f"value = {args.value}")["value"]
            except tomllib.TOMLDecodeError:
                print(f"rtctl set: {args.key}: VALUE must be written as in the configuration file "
                      f"(a number or an array like [1.0, 2.0]), got {args.value!r}", file=sys.stderr)
                return EXIT_CONFIG
    # a move is answered once it is planned and has started: planning may take seconds
    reply = request(path, args.command, timeout=120.0 if args.command == "move" else 5.0, **fields)
    print_json(reply)
    if reply.get("invalid"):  # the request itself was wrong (e.g. the number of joints)
        return EXIT_CONFIG
    return EXIT_OK if reply.get("ok", False) else EXIT_REFUSED
