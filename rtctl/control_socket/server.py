"""ControlServer: the daemon's end of the control socket, served from the loop thread.

Why ``poll()`` in the loop rather than a thread blocked in ``select()``: the loop must apply
stop / estop / move at a tick boundary, so a thread would still hand every request to the
loop and wait for its reply; and while that thread decodes a request it holds the GIL the
loop may need at its next wake-up. Polled from the loop (once per tick, or every k-th tick,
in the slack after ``write``/``record``), all the work happens where the loop chooses, and
each call is bounded: one zero-timeout ``poll`` syscall when idle (nothing else), at most
``ACCEPTS_PER_POLL`` accepts, one ``recv`` of at most 64 KiB + 4 bytes per ready connection
and one request handled per connection, at most ``max_clients`` connections; with a
``budget_s``, no further request is started once one has been served and the budget is spent —
the rest wait for the next poll, except ``stop`` and ``estop``, which are always served at once.
The handler runs in the loop thread: it must be quick (record the command for the next tick,
build the status reply) and hand anything longer elsewhere — it may return a :class:`Deferred`
and answer later (a ``move``, planned in another process).

A new connection is never refused, so ``estop`` and ``stop`` always get through: when
``max_clients`` connections are open, the one that has waited longest without a request is
dropped for the newcomer — closing ones first, then idle ones, then slow ones (mid-frame) —
and a newcomer's first request is read as soon as it is accepted. An idle connection is
closed after ``idle_timeout`` s (2 s), a frame must be complete within ``request_timeout`` s.
Idle or slow clients can therefore delay a newcomer by at most one poll, never lock it out.

Robustness: a request above the size limit, a frame cut short (the peer closed, or stalled
for ``request_timeout`` s mid-frame), malformed msgpack, an unknown command or wrong fields
get ``{"ok": False, "error": ...}``; the handler is not called and the server keeps serving.
A handler that raises answers ``ok: False`` too (and is logged): the loop never sees it.
At exit (``close(stopping=...)``) every request already sent is answered, none reset. While
``starting`` says what the daemon is doing before its loop runs, only stop and estop reach the
handler; any other request is answered at once that the daemon is starting (``ok: False``, with
``starting``), so no client waits for a loop that may be many seconds away.
"""
from __future__ import annotations

import os
import select
import socket
import stat
import time

import structlog

from rtctl.control_socket.connection import URGENT, Connection, Deferred, first_frame, frame_waiting, urgent
from rtctl.control_socket.framing import HEADER, decode, encode
from rtctl.control_socket.requests import MAX_REQUEST_BYTES, InvalidRequest, validate
from rtctl.errors import ControlSocketError, RtctlError

log = structlog.get_logger("rtctl.control_socket")

# epoll: one syscall per tick that costs ~0.5 µs against poll's ~0.8 (nothing to copy in per call)
_IN = select.EPOLLIN | select.EPOLLPRI
_OUT = select.EPOLLOUT
_BROKEN = select.EPOLLHUP | select.EPOLLERR
_MAX_PENDING_REPLY = 1 << 20  # a client that reads nothing back is dropped past this
ACCEPTS_PER_POLL = 4  # a connection storm costs a poll at most this many accepts
BACKLOG = 64  # connections the kernel queues between polls (a full queue makes connect() wait)


class ControlServer:
    """Listen on ``path`` (mode 0600) and answer requests with ``handler(request) -> dict``.

    ``n_joints``, when given, is checked against move targets. A live daemon already on
    ``path`` → :class:`ControlSocketError`; a stale socket file (nobody listening) is replaced.
    """

    def __init__(self, path, handler, *, n_joints: int | None = None, max_request: int = MAX_REQUEST_BYTES,
                 max_clients: int = 8, request_timeout: float = 2.0, idle_timeout: float = 2.0,
                 budget_s: float | None = None):
        if max_clients < 1:
            raise ValueError("max_clients must be >= 1")
        self.path = os.fspath(path)
        self.handler = handler
        self.n_joints = n_joints
        self.max_request = max_request
        self.max_clients = max_clients
        self.request_timeout = request_timeout
        self.idle_timeout = idle_timeout
        self.budget_ns = None if budget_s is None else int(budget_s * 1e9)
        self.starting: str | None = None  # what the daemon does before its loop: only stop/estop are handled
        self._serve_until = 0  # this poll's budget ends (monotonic ns)
        self._served = 0  # requests handled in this poll
        self._clients: dict[int, Connection] = {}
        self._pending: list[int] = []  # connections holding a further (pipelined) frame
        self._waiting: list[int] = []  # connections whose request's reply is Deferred
        self._next_sweep = 0.0
        self._remove_stale_socket()
        self._listener = self._bind()
        self._inode = os.stat(self.path).st_ino
        self._poller = select.epoll()
        self._poller.register(self._listener.fileno(), _IN)

    # ---- start-up and shutdown --------------------------------------------------------

    def _remove_stale_socket(self) -> None:
        try:
            mode = os.lstat(self.path).st_mode
        except FileNotFoundError:
            return
        if not stat.S_ISSOCK(mode):
            raise ControlSocketError(f"{self.path} exists and is not a socket; refusing to replace it")
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        probe.settimeout(1.0)
        try:
            probe.connect(self.path)
        except (ConnectionRefusedError, FileNotFoundError):
            try:  # nobody listens: a daemon died without cleaning up
                os.unlink(self.path)
            except FileNotFoundError:
                pass
            log.info("control_socket_stale_replaced", path=self.path)
            return
        except OSError as exc:  # busy (timeout) or not ours (permission): leave it alone
            raise ControlSocketError(f"control socket {self.path} is in use or not ours ({exc}); "
                                     "is another rtctl daemon running?") from exc
        finally:
            probe.close()
        raise ControlSocketError(f"another rtctl daemon is already listening on {self.path}; "
                                 "stop it (`rtctl stop`) or choose another --socket")

    def _bind(self) -> socket.socket:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old_umask = os.umask(0o177)  # the socket is born 0600: no window with wider permissions
        try:
            sock.bind(self.path)
        except OSError as exc:
            sock.close()
            raise ControlSocketError(f"cannot create control socket {self.path}: {exc}") from exc
        finally:
            os.umask(old_umask)
        os.chmod(self.path, 0o600)
        sock.listen(BACKLOG)
        sock.setblocking(False)
        return sock

    def close(self, stopping: str | None = None) -> None:
        """Close every connection and remove the socket file (if it is still ours); safe twice.

        ``stopping`` (why the daemon stops): answer first every request already sent — on an
        open connection, a move's reply resolved since the last poll, or a connection still in
        the accept queue — so that a client racing the daemon's exit gets a reason, not a reset
        connection: ``stop``/``estop`` are done (``ok``), anything else is refused naming it."""
        if self._listener is None:
            return
        if stopping is not None:
            self._answer_all(stopping)
        for fd in list(self._clients):
            self._drop(fd)
        self._listener.close()
        self._listener = None
        self._poller.close()
        try:
            if os.stat(self.path).st_ino == self._inode:
                os.unlink(self.path)
        except FileNotFoundError:
            pass

    def _answer_all(self, reason: str) -> None:
        """Bounded (the accept queue's BACKLOG, one drain per connection): run once, at exit."""
        for _ in range(BACKLOG):
            try:
                sock, _ = self._listener.accept()
            except OSError:  # (BlockingIOError: the queue is empty)
                break
            sock.setblocking(False)
            now = time.monotonic()
            self._clients[sock.fileno()] = Connection(sock, now, now)
            self._poller.register(sock, _IN)
        self._send_deferred()
        for fd, conn in list(self._clients.items()):
            asked = conn.drain(self.max_request + HEADER.size) or conn.waiting is not None
            if conn.closing or not asked:
                continue  # nothing asked (or answered already): a plain EOF will do
            done = conn.waiting is None and urgent(first_frame(conn.inbuf))
            conn.waiting = None
            conn.closing = True
            conn.inbuf.clear()
            self._reply(fd, conn, {"ok": True, "stopping": True} if done
                        else {"ok": False, "error": f"the daemon is stopping ({reason})", "stopping": True})

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- per tick ---------------------------------------------------------------------

    def poll(self) -> int:
        """Serve what is ready without blocking; returns the number of requests handled."""
        events = self._poller.poll(0)
        if not events and not self._clients:
            return 0
        handled = self._served = 0
        if self.budget_ns is not None:
            self._serve_until = time.monotonic_ns() + self.budget_ns
        if self._waiting:
            self._send_deferred()
        if self._pending:
            pending, self._pending = self._pending, []
            for fd in pending:
                if fd in self._clients:
                    handled += self._handle_frame(fd, self._clients[fd])
        listener_fd = self._listener.fileno()
        for fd, event in events:
            if fd == listener_fd:
                handled += self._accept()
                continue
            conn = self._clients.get(fd)
            if conn is None:
                continue
            if event & _OUT:
                self._send(fd, conn)
            if fd not in self._clients:
                continue
            if conn.closing:
                if event & _BROKEN:
                    self._drop(fd)
            elif event & (_IN | _BROKEN):
                handled += self._receive(fd, conn)
        if self._clients:
            self._sweep()
        return handled

    def _send_deferred(self) -> None:
        still = []
        for fd in self._waiting:
            conn = self._clients.get(fd)
            if conn is None or conn.waiting is None:
                continue
            if conn.waiting.reply is None:
                still.append(fd)
                continue
            reply, conn.waiting = conn.waiting.reply, None
            self._reply(fd, conn, reply)
            conn.last_request = time.monotonic()
            conn.deadline = conn.last_request + (self.request_timeout if conn.inbuf else self.idle_timeout)
            if conn.inbuf and fd in self._clients:
                self._pending.append(fd)
        self._waiting = still

    def _accept(self) -> int:
        """Accept what is queued (at most ACCEPTS_PER_POLL), making room by dropping the
        stalest connection, and serve each newcomer's first request if it is already here."""
        handled = 0
        for _ in range(ACCEPTS_PER_POLL):
            try:
                sock, _ = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:  # e.g. EMFILE: leave it queued, keep serving the others
                log.warning("control_accept_failed", error=str(exc))
                break
            if len(self._clients) >= self.max_clients:
                self._drop(min(self._clients, key=lambda fd: self._clients[fd].eviction_rank()))
            sock.setblocking(False)
            now = time.monotonic()
            fd = sock.fileno()
            conn = self._clients[fd] = Connection(sock, now, now + self.idle_timeout)
            self._poller.register(sock, _IN)
            handled += self._receive(fd, conn)
        return handled

    def _receive(self, fd: int, conn: Connection) -> int:
        if frame_waiting(conn.inbuf):
            return 0  # serve it (via _pending) before reading on — the end of the stream too
        try:
            data = conn.sock.recv(self.max_request + HEADER.size)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            data = b""
        if not data:  # the peer closed (or shut down its sending side)
            if conn.inbuf:
                self._fail(fd, conn, self._truncated_message(conn.inbuf))
            else:
                self._drop(fd)
            return 0
        conn.inbuf += data
        return self._handle_frame(fd, conn)

    def _handle_frame(self, fd: int, conn: Connection) -> int:
        if conn.waiting is not None:  # one request at a time per connection, answered in order
            return 0
        if len(conn.inbuf) < HEADER.size:
            conn.deadline = time.monotonic() + self.request_timeout
            return 0
        (length,) = HEADER.unpack_from(conn.inbuf)
        if length > self.max_request:
            self._fail(fd, conn, f"request of {length} bytes exceeds the {self.max_request}-byte limit")
            return 0
        if len(conn.inbuf) < HEADER.size + length:
            conn.deadline = time.monotonic() + self.request_timeout
            return 0
        body = bytes(conn.inbuf[HEADER.size:HEADER.size + length])
        if self._over_budget() and not urgent(body):
            self._pending.append(fd)  # served first at the next poll (that serves it)
            conn.deadline = float("inf")  # waiting its turn is not stalling mid-frame
            return 0
        del conn.inbuf[:HEADER.size + length]
        self._served += 1
        reply = self._answer(body)
        if isinstance(reply, Deferred):
            conn.waiting, conn.deadline = reply, float("inf")
            self._waiting.append(fd)
            return 1
        self._reply(fd, conn, reply)
        conn.last_request = time.monotonic()
        if conn.inbuf and fd in self._clients:
            # Pipelined bytes: poll() has no news about them, and one request per connection
            # per call keeps the call bounded, so they are served at the next call.
            self._pending.append(fd)
        conn.deadline = time.monotonic() + (self.request_timeout if conn.inbuf else self.idle_timeout)
        return 1

    def _over_budget(self) -> bool:
        """This poll has served a request and spent its budget: the rest waits for the next
        poll (a stop or an e-stop never waits: see _urgent)."""
        return self.budget_ns is not None and self._served > 0 and time.monotonic_ns() >= self._serve_until

    def _answer(self, body: bytes) -> dict:
        try:
            request = validate(decode(body), self.n_joints)
        except (InvalidRequest, ValueError) as exc:  # the request's shape: the client's to correct
            return {"ok": False, "error": str(exc), "invalid": True}
        if self.starting is not None and request["cmd"] not in URGENT:
            return {"ok": False, "starting": self.starting,
                    "error": f"the daemon is starting ({self.starting}): only stop and estop are served until its "
                             f"loop runs; ask again (`status` answers ok once it runs)"}
        try:
            reply = self.handler(request)
        except RtctlError as exc:
            return {"ok": False, "error": str(exc)}
        except Exception as exc:  # a bug in the handler must not reach the loop
            log.exception("control_handler_failed", cmd=request["cmd"])
            return {"ok": False, "error": f"internal error handling {request['cmd']!r}: {exc!r}"}
        if isinstance(reply, Deferred):
            return reply
        reply = {} if reply is None else dict(reply)
        reply.setdefault("ok", True)
        return reply

    def _reply(self, fd: int, conn: Connection, reply: dict) -> None:
        try:
            frame = encode(reply)
        except (TypeError, ValueError) as exc:
            log.error("control_reply_unencodable", error=str(exc))
            frame = encode({"ok": False, "error": f"reply could not be encoded: {exc}"})
        conn.outbuf += frame
        self._send(fd, conn)

    def _send(self, fd: int, conn: Connection) -> None:
        try:
            sent = conn.sock.send(conn.outbuf) if conn.outbuf else 0
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError:  # the client went away; nothing more to tell it
            self._drop(fd)
            return
        del conn.outbuf[:sent]
        if len(conn.outbuf) > _MAX_PENDING_REPLY or (conn.closing and not conn.outbuf):
            self._drop(fd)
            return
        # A closing connection is no longer read; an unsent reply waits for EPOLLOUT.
        self._poller.modify(conn.sock, (0 if conn.closing else _IN) | (_OUT if conn.outbuf else 0))

    def _fail(self, fd: int, conn: Connection, error: str) -> None:
        """A framing error: the stream cannot be resynchronised, so reply and close."""
        conn.closing = True
        conn.inbuf.clear()
        self._reply(fd, conn, {"ok": False, "error": error})

    def _truncated_message(self, inbuf: bytearray) -> str:
        if len(inbuf) < HEADER.size:
            return f"truncated request: {len(inbuf)} of the 4 length bytes"
        (length,) = HEADER.unpack_from(inbuf)
        return f"truncated request: {len(inbuf) - HEADER.size} of {length} bytes"

    def _sweep(self) -> None:
        """Time out stalled connections; at most every 0.1 s, and only while clients exist."""
        now = time.monotonic()
        if now < self._next_sweep:
            return
        self._next_sweep = now + 0.1
        for fd, conn in list(self._clients.items()):
            if now < conn.deadline:
                continue
            if conn.inbuf and not conn.closing:
                self._fail(fd, conn, self._truncated_message(conn.inbuf) + f" after {self.request_timeout:g} s")
                conn.deadline = now + 1.0  # then give the reply a second to leave
            else:
                self._drop(fd)

    def _drop(self, fd: int) -> None:
        conn = self._clients.pop(fd)
        try:
            self._poller.unregister(fd)
        except (KeyError, OSError):  # (epoll: EBADF/ENOENT for an fd already gone)
            pass
        conn.sock.close()
