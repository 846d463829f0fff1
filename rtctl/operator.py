"""What the control socket's commands do to a running daemon (docs/operations.md).

:meth:`Operator.handle` runs in the loop's thread, at a tick boundary (the server polls after
the tick): every command does a small, bounded amount of work — flags for the next tick, a
status reply, the hand-over of a ``move`` to the planner process — and nothing that waits.

* ``stop`` — a controlled stop, then the daemon exits; a pending move is cancelled;
* ``estop`` — latched now, acted on at the next tick (damping, then drives off); the daemon
  stays up; a pending move is cancelled;
* ``reset`` — clears the faults whose cause is gone and re-enables every device, all or none;
* ``move`` — planned in another process (:mod:`rtctl.moves`), answered once started;
* ``status`` — where the robot is and what the daemon is doing (with a cell's shared zones:
  each lease, whether the path waits for it);
* ``lease`` — a shared zone's lease granted or dropped (:mod:`rtctl.cell.shared`);
* ``controllers``, ``switch``, ``get``, ``set`` — live changes (:mod:`rtctl.live`).
"""
from __future__ import annotations

import structlog

from rtctl.errors import RtctlError
from rtctl.safety import Verdict
from rtctl.trajectory import hold

log = structlog.get_logger("rtctl.daemon")


class Operator:
    """The commands, on the daemon ``d`` (its stop flag, safety stage, devices, trajectory)."""

    def __init__(self, daemon):
        self.d = daemon

    def handle(self, req: dict):
        cmd = req["cmd"]
        if cmd == "status":
            return self.status()
        if cmd == "stop":
            return self.stop()
        if cmd == "estop":
            return self.estop()
        if cmd == "reset":
            return self.reset()
        if cmd == "move":
            return self.move(req)
        if cmd == "lease" and self.d.zones is not None:
            s = self.d.rt.state
            return self.d.zones.lease(req, self.d.ticker.sim_time_s, s.position, s.velocity)
        if cmd == "controllers":
            return self.d.live.controllers()
        if cmd == "switch":
            return self.d.live.switch(req)
        if cmd == "get":
            return self.d.live.get(req)
        if cmd == "set":
            return self.d.live.set(req)
        raise RtctlError(f"unknown command {cmd!r}")

    def stop(self) -> dict:
        d = self.d
        if d.stop_reason is None:
            d.stop_reason = "stop requested"
        d.moves.cancel(d.stop_reason)
        return {"ok": True, "stopping": True, "t": d.ticker.sim_time_s}

    def estop(self) -> dict:
        d = self.d
        d.safety.estop("operator e-stop")
        d.moves.cancel("operator e-stop")
        if not d.estopped and d.stop_reason is None:
            d.estopped = True
            log.warning("e-stop", detail="damping, then drives off; `rtctl reset` re-enables them, "
                                         "`rtctl stop` ends the daemon" if d.running else
                                         "before the first tick: the daemon ends with every drive off")
        return {"ok": True, "t": d.ticker.sim_time_s}  # latched in this tick, acted on at the next

    def reset(self) -> dict:
        """Clear the faults whose cause is gone; then hold where the robot is (the old
        reference moved on while the fallback held) with fresh controllers, and re-enable every
        device — all of them or none: if one cannot be activated, every device is put back in
        its safe state and the e-stop latched again, and the reply names the device."""
        d = self.d
        if d.stop_reason is not None:
            raise RtctlError(f"the daemon is stopping ({d.stop_reason})")
        d.moves.cancel("reset")
        if not d.safety.reset():
            return {"ok": False, "faults": [f.reason for f in d.safety.faults]}
        t = d.ticker.sim_time_s
        d.hand_over(hold(d.rt.state.position.copy(), t), t)
        for dev in d.rt.all_devices:
            try:
                dev.activate()
            except Exception as e:
                return self._reset_failed(dev, e)
        d.estopped = False
        return {"ok": True, "faults": []}

    def _reset_failed(self, dev, e: Exception) -> dict:
        d = self.d
        why = f"reset failed: device {dev.name} could not be re-enabled ({type(e).__name__}: {e})"
        log.error("reset failed", device=dev.name, reason=f"{type(e).__name__}: {e}")
        d.safety.estop(why)
        for other in d.rt.all_devices:
            other.safe_state()
        d.deactivate_all()
        d.estopped = True
        return {"ok": False, "error": why + "; every device is back in its safe state, drives off",
                "faults": [f.reason for f in d.safety.faults]}

    def move(self, req: dict):
        """Hand the move to the planner process (:mod:`rtctl.moves`): the reply comes once it
        is planned and swapped in at a tick, or refused; "busy" while another is pending."""
        d = self.d
        if d.stop_reason is not None:
            raise RtctlError(f"move refused: the daemon is stopping ({d.stop_reason})")
        if d.estopped or d.safety.faulted:
            raise RtctlError("move refused: faults are latched: `rtctl reset` first")
        return d.moves.request(req, d.ticker.sim_time_s, d.tick.trajectory)

    def status(self) -> dict:
        d = self.d
        s = d.rt.state
        return {"ok": True, "robot": d.model.name, "t": d.ticker.sim_time_s, "tick": d.ticker.tick,
                "q": s.position.tolist(), "qd": s.velocity.tolist(), "q_des": d.rt.ref.q.tolist(),
                "verdict": Verdict(d.tick.verdict).name, "faults": [f.reason for f in d.safety.faults],
                "overruns": d.ticker.stats.overruns, "estopped": d.estopped, "move": d.moves.state,
                "stopping": d.stop_reason,
                **({} if d.zones is None else {"zones": d.zones.status(d.ticker.sim_time_s, s.position, s.velocity),
                                               "gate": d.zones.gate_status()})}
