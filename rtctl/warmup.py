"""Preparing a run's numba kernels before the loop starts: in parallel, and saying so.

The first run on a machine (or after any change of the sources) compiles every kernel its
configuration uses; numba keeps them on disk (:mod:`rtctl.kernel_cache`), so later runs only
load them. :class:`Precompile` takes the run's warm-up groups (a device's step, a controller's
update, the safety stage's paths …) and

1. runs them in the daemon's process until one would compile (numba reports a cache miss) —
   a later run loads everything here in about a second and forks nothing;
2. hands the rest to forked workers — up to one per core, each taking the next group when it
   has finished its last — which fill the cache while the daemon goes on (real-time knobs,
   configuring the devices);
3. logs each group as it is ready and, every second without news, what it waits for (from a
   sleeping helper thread, gone before the loop starts), so a first run is never silent;
   :meth:`~Precompile.wait` waits for the workers;
4. :meth:`~Precompile.finish` runs the rest in the daemon's process, which now only loads them.

Workers are forked before the daemon applies its real-time knobs, so they compile with
ordinary scheduling and no locked memory. A worker that fails costs only time: ``finish``
compiles what is missing (saying so every second) and raises any real error itself.
"""
from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import threading
import time
from typing import Callable

import structlog

log = structlog.get_logger("rtctl.warmup")

HEARTBEAT_S = 1.0  # the longest the daemon stays silent while kernels load or compile
STOP_CHECK_S = 0.01  # how often wait() asks whether to stop
NOTE = "the first run after an install or update compiles them; later runs load them from the cache"

Group = tuple[str, Callable[[], object]]


class _CacheMiss(BaseException):
    """Raised by the probe when numba starts a compilation (a BaseException: no ``except
    Exception`` in a group swallows it)."""


def count_compilations(fn: Callable[[], object]) -> int:
    """Run ``fn``; return how many numba functions it compiled (0: all loaded from the cache)."""
    from numba.core.event import install_recorder

    with install_recorder("numba:compile") as recorder:
        fn()
    return sum(1 for _, ev in recorder.buffer if ev.is_start)


class Precompile:
    """The run's warm-up groups ``[(name, fn), …]``, prepared as the module docstring says.

    Workers take the groups in the order given — put first what others share (a simulated
    plant compiles the whole dynamics library), so that a later group finds it in the cache.
    """

    def __init__(self, groups: list[Group]):
        self.groups = groups
        self.loaded = 0  # groups[:loaded] ran in this process
        self.current: str | None = None  # the group running in this process
        self.queue: list[int] = []
        self.pending: set[str] = set()  # groups the workers have not reported yet
        self.workers: dict[int, _Worker] = {}  # report fd → worker
        self.started = self.last_line = time.monotonic()  # when it last logged
        self._beat: tuple[threading.Thread, threading.Event] | None = None

    @property
    def done(self) -> bool:
        """Every group ran in this process: nothing is left to compile or to load."""
        return self.loaded == len(self.groups)

    def start(self, loading: contextlib.AbstractContextManager | None = None,
              stop: Callable[[], bool] = lambda: False) -> "Precompile":
        """Load what is cached here, then fork the workers for the rest. ``loading`` is
        entered while the kernels load and left before any fork (the daemon serves its socket
        from a thread meanwhile: a fork must not copy a thread's locks). ``stop()`` is asked
        after each group: once true, nothing more loads and no worker is forked."""
        with loading or contextlib.nullcontext():
            self._start_heartbeat()
            try:
                self._probe(stop)
            finally:
                self._stop_heartbeat()
        if self.done:
            log.info("kernels loaded", seconds=round(time.monotonic() - self.started, 2), compiled=0)
            return self
        if stop():
            log.info("kernels not prepared", reason="a stop came while they loaded",
                     left=[name for name, _ in self.groups[self.loaded:]])
            return self
        self.queue = list(range(self.loaded, len(self.groups)))
        self.pending = {self.groups[i][0] for i in self.queue}
        n = min(len(os.sched_getaffinity(0)), len(self.queue))  # one worker per core at most
        if threading.active_count() > 1:  # a fork keeps only this thread: a lock another holds stays held
            log.debug("kernels compile in the daemon", reason="other threads are running")
            n = 0
        log.info("preparing kernels", compile=[self.groups[i][0] for i in self.queue], workers=n, note=NOTE)
        self.last_line = time.monotonic()
        for _ in range(n):
            worker = _Worker.fork(self.groups)
            self.workers[worker.reports] = worker
            self._assign(worker)
        if self.workers:
            self._start_heartbeat()  # the threads come after the forks
        return self

    def _probe(self, stop: Callable[[], bool]) -> None:
        """Run the groups here while numba finds them in its cache; stop at the first miss, or
        when ``stop()``."""
        from numba.core.event import Listener, install_listener

        class Miss(Listener):
            def on_start(self, event):
                raise _CacheMiss

            def on_end(self, event):
                pass

        with install_listener("numba:compile", Miss()):
            for name, fn in self.groups:
                if stop():
                    return
                self.current = name
                try:
                    fn()
                except _CacheMiss:
                    return
                finally:
                    self.current = None
                self.loaded += 1

    def _assign(self, worker: "_Worker") -> None:
        """Hand ``worker`` the next group, or tell it to leave."""
        worker.give(self.queue.pop(0) if self.queue else None)

    def wait(self, stop: Callable[[], bool] = lambda: False) -> bool:
        """Until every worker has finished (True) or ``stop()`` (False, the workers stopped),
        logging each group as it is ready; ``stop()`` is asked every ``STOP_CHECK_S``."""
        try:
            while self.workers:
                if stop():
                    self.abort()
                    return False
                ready, _, _ = select.select(list(self.workers), [], [], STOP_CHECK_S)
                for fd in ready:
                    self._read(self.workers[fd])
        except BaseException:
            self.abort()
            raise
        self._stop_heartbeat()
        return True

    def finish(self) -> None:
        """Run the groups the probe did not reach in this process (loading what the workers
        compiled; compiling, and saying so every second, what a failed worker left)."""
        if self.done:
            return
        t0 = time.monotonic()

        def rest():
            for name, fn in self.groups[self.loaded:]:
                self.current = name
                fn()
            self.current = None

        self._start_heartbeat()
        try:
            compiled = count_compilations(rest)
        finally:
            self._stop_heartbeat()
        self.loaded = len(self.groups)
        log.info("kernels loaded", seconds=round(time.monotonic() - t0, 2), compiled=compiled)

    def _read(self, worker: "_Worker") -> None:
        """Take a worker's output, log what it says."""
        chunk = os.read(worker.reports, 4096)
        if not chunk:  # the worker has left
            del self.workers[worker.reports]
            code = worker.reap()
            if code != 0:
                log.warning("kernel worker failed", exit_code=code, group=worker.group_name,
                            detail="the daemon compiles what is missing itself")
                self.last_line = time.monotonic()
            return
        worker.buffer.extend(chunk)
        while b"\n" in worker.buffer:
            line, _, rest = bytes(worker.buffer).partition(b"\n")
            worker.buffer[:] = rest
            report = json.loads(line)
            self.pending.discard(report["group"])
            if "error" in report:
                log.warning("kernel group failed", group=report["group"], error=report["error"],
                            detail="the daemon compiles it itself")
            else:
                log.info("kernels ready", group=report["group"], seconds=report["seconds"],
                         compiled=report["compiled"])
            self.last_line = time.monotonic()
            self._assign(worker)

    def abort(self) -> None:
        """Stop and reap the workers (the daemon is leaving before they finished)."""
        self._stop_heartbeat()
        for worker in self.workers.values():
            worker.kill()
        self.workers.clear()

    # -- the heartbeat: a sleeping thread, while kernels load here or compile in the workers --
    def _start_heartbeat(self) -> None:
        done = threading.Event()
        thread = threading.Thread(target=self._heartbeat, args=(done,), name="rtctl-kernels-heartbeat", daemon=True)
        self._beat = thread, done
        thread.start()

    def _stop_heartbeat(self) -> None:
        if self._beat is not None:
            thread, done = self._beat
            done.set()
            thread.join()
            self._beat = None

    def _heartbeat(self, done: threading.Event) -> None:
        while not done.wait(HEARTBEAT_S / 4):
            now = time.monotonic()
            if now - self.last_line < HEARTBEAT_S:
                continue
            self.last_line = now
            if self.workers:
                log.info("compiling kernels", elapsed_s=round(now - self.started, 1),
                         ready=f"{len(self.groups) - len(self.pending)}/{len(self.groups)}",
                         waiting_for=sorted(self.pending))
            else:
                log.info("loading kernels", elapsed_s=round(now - self.started, 1), group=self.current)


class _Worker:
    """One forked compiler: group indices in on one pipe, a JSON report per group out on another."""

    def __init__(self, groups: list[Group], pid: int, tasks: int, reports: int):
        self.groups, self.pid, self.tasks, self.reports = groups, pid, tasks, reports
        self.buffer = bytearray()
        self.group_name: str | None = None  # the group it works on

    @classmethod
    def fork(cls, groups: list[Group]) -> "_Worker":
        task_r, task_w = os.pipe()
        report_r, report_w = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(task_w)
            os.close(report_r)
            _work(groups, task_r, report_w)  # never returns
        os.close(task_r)
        os.close(report_w)
        return cls(groups, pid, task_w, report_r)

    def give(self, index: int | None) -> None:
        if index is None:  # no more work: end of its task stream
            os.close(self.tasks)
            self.tasks, self.group_name = -1, None
            return
        self.group_name = self.groups[index][0]
        try:
            os.write(self.tasks, b"%d\n" % index)
        except BrokenPipeError:  # it has just died: the end of its reports says so
            pass

    def reap(self) -> int:
        self._close()
        return os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])

    def kill(self) -> None:
        try:
            os.kill(self.pid, signal.SIGKILL)  # a compiler has nothing to clean up; numba writes its cache atomically
            os.waitpid(self.pid, 0)
        except (ProcessLookupError, ChildProcessError):
            pass
        self._close()

    def _close(self) -> None:
        for fd in (self.tasks, self.reports):
            if fd >= 0:
                os.close(fd)
        self.tasks = self.reports = -1


def _work(groups: list[Group], tasks: int, reports: int) -> None:
    """A worker: run the groups it is handed, report each as a JSON line, and leave without
    running the parent's exit handlers (they own the devices, the socket and the telemetry)."""
    code = 0
    try:
        # the daemon's handlers only set its stop flag: here Ctrl-C is the daemon's to answer
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)  # whatever a group logs is the daemon's business, not the worker's
        for line in os.fdopen(tasks, "rb", buffering=0):
            name, fn = groups[int(line)]
            t0 = time.monotonic()
            try:
                report = {"group": name, "compiled": count_compilations(fn),
                          "seconds": round(time.monotonic() - t0, 2)}
            except Exception as e:  # reported; the daemon's own run of the group raises it properly
                report = {"group": name, "error": f"{type(e).__name__}: {e}"}
            os.write(reports, (json.dumps(report) + "\n").encode())
    except BaseException:
        code = 1
    finally:
        os._exit(code)
