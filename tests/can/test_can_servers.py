"""The socketcand server and the slcan adapter at the byte level (handshake, states, errors),
and both run standalone as their own process, announcing where they listen."""
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time

import can
import pytest

from drivers.protocols import mit
from hil_sim.mit_drive import stand_in_bus
from hil_sim.slcan import SlcanAdapter
from hil_sim.socketcand import SocketcandServer

pytestmark = pytest.mark.realtime  # (tests/conftest.py)


def read_until(sock, count, timeout=2.0):
    """Bytes from ``sock`` until ``count`` '>' have arrived (the timeout bounds a failure)."""
    data, end = b"", time.monotonic() + timeout
    while data.count(b">") < count and time.monotonic() < end:
        if select.select([sock], [], [], 0.05)[0]:
            chunk = sock.recv(4096)
            if not chunk:
                break
            data += chunk
    return data


def closed_by_server(sock):
    return bool(select.select([sock], [], [], 2.0)[0]) and sock.recv(100) == b""


@pytest.fixture
def socketcand():
    server = SocketcandServer([stand_in_bus([1, 2], name="arm", timeout_s=10.0), stand_in_bus([1], name="leg")])
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    socks = []

    def connect():
        s = socket.create_connection(server.address)
        socks.append(s)
        assert read_until(s, 1) == b"< hi >"
        return s

    yield server, connect
    for s in socks:
        s.close()
    server.shutdown()
    thread.join(5)


def test_socketcand_handshake_and_raw_frames(socketcand):
    server, connect = socketcand
    s = connect()
    s.sendall(b"< open arm >")
    assert read_until(s, 1) == b"< ok >"
    s.sendall(b"< send 001 8 ff ff ff ff ff ff ff fc >")  # before rawmode: the drive acts, the client gets no frame
    s.sendall(b"< echo >")
    assert read_until(s, 1) == b"< echo >"
    s.sendall(b"< rawmode >")
    assert read_until(s, 1) == b"< ok >"
    s.sendall(b"< send 002 8 ff ff ff ff ff ff ff fc >< send 002 3 1 2 3 >")  # two in one segment
    text = read_until(s, 1).decode()
    words = text[1:-1].split()
    assert words[:2] == ["frame", "000"] and words[2].count(".") == 1 and len(words[2].split(".")[1]) == 6
    assert bytes.fromhex(words[3])[0] == 2 and len(bytes.fromhex(words[3])) == 6
    assert server.buses["arm"].drives[1].enabled and server.buses["arm"].drives[2].enabled
    assert server.buses["arm"].drives[2].counters.malformed == 1  # the 3-byte frame


def test_socketcand_bad_input(socketcand):
    server, connect = socketcand
    s = connect()
    s.sendall(b"< open nosuchbus >")
    assert read_until(s, 1) == b"< error could not open bus >"
    assert closed_by_server(s)
    s = connect()
    s.sendall(b"< open leg >< rawmode >")
    assert read_until(s, 2) == b"< ok >< ok >"
    s.sendall(b"< send 001 8 1 2 >< send 001 x >< jump >")
    assert read_until(s, 1) == b"< error unknown command >"
    assert server.counters["syntax_errors"] == 3


def test_socketcand_other_clients_see_the_bus(socketcand):
    server, connect = socketcand
    a, b = connect(), connect()
    for s in (a, b):
        s.sendall(b"< open arm >< rawmode >")
        assert read_until(s, 2) == b"< ok >< ok >"
    a.sendall(b"< send 1ABCDEF0 2 1 f1 >")  # extended id: nobody on the bus answers
    words = read_until(b, 1).decode()[1:-1].split()
    assert words[0] == "frame" and words[1] == "1ABCDEF0" and words[3] == "01F1"
    # the sender does not get its own frame back: the server answers in order, so an echo asked
    # for after the send is the first thing that arrives (no waiting for an absence)
    a.sendall(b"< echo >")
    assert read_until(a, 1) == b"< echo >"
    assert server.buses["arm"].ignored == 1


def test_socketcand_dropped_connection_can_reconnect(socketcand):
    server, connect = socketcand
    s = connect()
    s.sendall(b"< open arm >< rawmode >")
    assert read_until(s, 2) == b"< ok >< ok >"
    server.drop_connections()
    assert closed_by_server(s)
    s = connect()
    s.sendall(b"< open arm >< rawmode >< send 001 8 ff ff ff ff ff ff ff fc >")
    assert read_until(s, 3).startswith(b"< ok >< ok >< frame 000 ")


@pytest.fixture
def slcan():
    adapter = SlcanAdapter(stand_in_bus([1], timeout_s=10.0))
    thread = threading.Thread(target=adapter.serve_forever, daemon=True)
    thread.start()
    fd = os.open(adapter.path, os.O_RDWR | os.O_NOCTTY)

    def ask(command: bytes, answers=1) -> bytes:
        os.write(fd, command)
        data, end = b"", time.monotonic() + 2.0
        while (data.count(b"\r") + data.count(b"\a")) < answers and time.monotonic() < end:
            if select.select([fd], [], [], 0.05)[0]:
                data += os.read(fd, 4096)
        return data

    yield adapter, ask
    os.close(fd)
    adapter.shutdown()
    thread.join(5)


def test_slcan_lawicel_commands(slcan):
    adapter, ask = slcan
    assert ask(b"V\r") == b"V1013\r"
    assert ask(b"N\r") == b"NRTSM\r"
    assert ask(b"t0018FFFFFFFFFFFFFFFC\r") == b"\a"  # closed: no transmit
    assert ask(b"C\r") == b"\r"
    assert ask(b"S8\r") == b"\r"
    assert ask(b"\r") == b"\r"
    assert ask(b"O\r") == b"\r"
    assert ask(b"S6\r") == b"\a" and ask(b"O\r") == b"\a"  # only while closed
    reply = ask(b"t0018FFFFFFFFFFFFFFFC\r", answers=2)
    assert reply.startswith(b"z\rt0006") and len(reply) == 2 + 18  # ack, then the drive's reply
    assert bytes.fromhex(reply[7:19].decode())[0] == 1 and adapter.bus.drives[1].enabled
    assert ask(b"t00181234\r") == b"\a"  # DLC 8 with two bytes
    assert ask(b"d0018FFFFFFFFFFFFFFFC\r") == b"\a"  # CAN FD: not this adapter
    assert ask(b"T000000AB0\r") == b"Z\r" and adapter.bus.ignored == 1
    assert ask(b"C\r") == b"\r"
    assert adapter.counters["errors"] == 5


@pytest.mark.parametrize("module, args", [("hil_sim.socketcand", ["--ids", "3", "4"]), ("hil_sim.slcan", ["--ids", "3"])])
def test_standalone_server_announces_itself_and_stops_on_sigterm(module, args):
    proc = subprocess.Popen([sys.executable, "-m", module, *args], stdout=subprocess.PIPE, text=True)
    try:
        assert select.select([proc.stdout], [], [], 30)[0], "no announcement"
        info = json.loads(proc.stdout.readline())
        assert info["channels"] == ["can0"]
        if info["transport"] == "socketcand":
            bus = can.Bus(interface="socketcand", host=info["host"], port=info["port"], channel="can0", tcp_tune=True)
        else:
            bus = can.Bus(interface="slcan", channel=info["tty"], sleep_after_open=0)
        try:
            drive = int(args[1])
            bus.send(can.Message(arbitration_id=drive, data=mit.special_frame(mit.Special.ENTER_MOTOR_MODE), is_extended_id=False))
            reply = bus.recv(5.0)
            assert reply is not None and mit.unpack_reply(reply.data, mit.KATZ).drive_id == drive
        finally:
            bus.shutdown()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
