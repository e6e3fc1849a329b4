"""The bench's side of steering from the app: pause, resume, single-step and speed of a
lockstep run, and catalogue faults injected on ``/hil/inject``.

Commands come from the live server (hil/live/server.py) through a pipe and are only queued
when they arrive; they take effect at tick boundaries, so a run that is never steered flies
exactly as without ``--live``:

* pause, resume, step and speed in the tick loop's gate (``TickLoop.tick_gate``), before
  sim time moves to the next tick. On virtual time the flight code then waits with the
  bench's clock, as under a debugger; the flight it records is the same however long the
  pause. Realtime runs (and lockstep on the host clock) refuse them with an event;
* faults at the start of the next tick (``before_tick``), validated by the same path as a
  scenario's ``[[faults]]`` (``FaultSchedule.start_now``), and recorded as events;
* the app's seek: forward, the run steps to the requested time and pauses there; backward, it
  is refused with an event (a live run cannot go back: open its MCAP to scrub).

The server's own trouble comes back on the same pipe: messages it could not serve are events
and a note in the summary. If the server's process ends, steering ends: a paused run goes on,
and the summary says so.

Every command, accepted or refused, is an event on ``/hil/events`` (``kind = "live"``); a bad
one changes nothing else.
"""

from __future__ import annotations

import asyncio
import json
import os
import pickle
from collections.abc import Awaitable, Callable
from typing import Any

from hil import clock
from hil.config import ConfigError
from hil.live.topics import INJECT_TOPIC, LEN, STEER_TOPIC

EventLogger = Callable[[int, str, str, dict[str, Any]], None]
Note = Callable[[str], None]
#: the message text quoted in an error event (a client's mistake must not bloat the log)
QUOTE_CHARS = 200


class Steering:
    """Reads the app's commands from ``fd`` and applies them to ``loop`` (a TickLoop) and the
    ``runner``'s fault schedule; ``lockstep``: pause and speed allowed."""

    def __init__(self, fd: int, loop: Any, runner: Any, log_event: EventLogger, *, lockstep: bool,
                 flush: Callable[[], None] = lambda: None, note: Note = lambda text: None,
                 run_start_unix_ns: int = 0) -> None:
        self.fd = fd
        #: a line for the run's summary and the MCAP's notes
        self.note = note
        #: the app's timeline: log time = this + sim time (seek requests are in log time)
        self.run_start_unix_ns = run_start_unix_ns
        #: messages the live server failed to serve, as last reported by it (the recording has them)
        self.server_errors = 0
        self._first_server_error = ""
        self.server_gone = False
        #: hands what was logged to the recorder now (the run logger batches a tick's messages;
        #: a paused run's events must not wait for the next tick)
        self.flush = flush
        self.loop = loop
        self.runner = runner
        self.log_event = log_event
        self.lockstep = lockstep
        self.paused = False
        self.speed = 0.0  #: x real time; 0 = as fast as possible
        self._steps = 0  #: ticks still to run while paused
        self._buf = bytearray()
        self._steer: list[Any] = []  #: pause/resume/step/speed commands, in arrival order
        self._injects: list[bytes] = []
        self._wake = asyncio.Event()
        self._gated = False  #: the tick loop calls the gate (lockstep on virtual time)
        self._anchor: tuple[int, int] = (0, 0)  #: (sim ns, host ns) speed pacing counts from
        self._prev_gate: Callable[[], Awaitable[None]] | None = None
        self._prev_before: Callable[[int, int], None] | None = None
        self._aio: asyncio.AbstractEventLoop | None = None

    # -- wiring ----------------------------------------------------------------------------------
    def attach(self) -> None:
        self._aio = asyncio.get_running_loop()
        self._aio.add_reader(self.fd, self._readable)
        self._prev_gate, self.loop.tick_gate = self.loop.tick_gate, self._gate
        self._prev_before, self.loop.before_tick = self.loop.before_tick, self._before_tick

    def close(self) -> None:
        if self.fd >= 0 and self.server_errors:
            self.note(f"live view: the server could not serve {self.server_errors} message(s) "
                      f"(first: {self._first_server_error}); the recording has them")
        self._close_fd()

    def _close_fd(self) -> None:
        if self._aio is not None and self.fd >= 0:
            self._aio.remove_reader(self.fd)
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
        self.paused, self._steps = False, 0
        self._wake.set()  # a gate still waiting lets the run go on or end

    def _server_gone(self) -> None:
        """The server's end of the pipe closed (its process died): no more steering, and a
        paused run must not wait for a resume that cannot come."""
        self.server_gone = True
        t_s = self._t_ns / 1e9
        self._event("server gone", {"t_s": t_s, "server_errors": self.server_errors})
        self.note(f"live view: the live server ended at t = {t_s:.3f} s; the run went on without it"
                  + (f" ({self.server_errors} message(s) it could not serve, first: {self._first_server_error})"
                     if self.server_errors else ""))
        self._close_fd()

    def _readable(self) -> None:
        try:
            chunk = os.read(self.fd, 65536)
        except BlockingIOError:
            return
        except OSError:
            chunk = b""
        if not chunk:  # the server's process ended
            self._server_gone()
            return
        self._buf += chunk
        while len(self._buf) >= LEN.size:
            (n,) = LEN.unpack_from(self._buf)
            if len(self._buf) < LEN.size + n:
                break
            item = pickle.loads(bytes(self._buf[LEN.size:LEN.size + n]))
            del self._buf[:LEN.size + n]
            if item[0] == "publish" and item[1] == INJECT_TOPIC:
                self._injects.append(item[2])
            elif item[0] == "server error":
                self._on_server_error(item[1], item[2])
            else:
                self._steer.append(item)
        self._wake.set()

    def _on_server_error(self, count: int, text: str) -> None:
        if not self._first_server_error:
            self._first_server_error = text[:QUOTE_CHARS]
        self.server_errors = max(self.server_errors, int(count))
        self._event("server error", {"errors": self.server_errors, "error": text[:QUOTE_CHARS]})

    @property
    def _t_ns(self) -> int:
        return max(int(self.loop.t_ns), 0)

    def _event(self, name: str, detail: dict[str, Any]) -> None:
        self.log_event(self._t_ns, "live", name, detail)
        self.flush()

    def _refuse(self, topic: str, reason: str, raw: bytes | str = b"") -> None:
        text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else raw
        self._event("error", {"topic": topic, "error": reason, "message": text[:QUOTE_CHARS]})

    # -- steering ----------------------------------------------------------------------------------
    async def _gate(self) -> None:
        if self._prev_gate is not None:
            await self._prev_gate()
        self._gated = True
        self._apply_steer()
        if self.paused and self._steps == 0 and self.fd >= 0:
            self._event("paused", {"t_s": self._t_ns / 1e9})  # where a pause or a step stopped
        while self.paused and self._steps == 0 and self.fd >= 0:
            self._wake.clear()
            await self._wake.wait()
            self._apply_steer()
        if self.paused and self._steps > 0:
            self._steps -= 1
        elif self.speed > 0:
            await self._pace()

    async def _pace(self) -> None:
        t0, h0 = self._anchor
        t_next = (int(self.loop.k) + 1) * int(self.loop.tick_ns)
        wait_ns = h0 + round((t_next - t0) / self.speed) - clock.monotonic_ns()
        if wait_ns > 0:
            await asyncio.sleep(wait_ns / 1e9)

    def _apply_steer(self) -> None:
        items, self._steer = self._steer, []
        for item in items:
            command = self._command(item)
            if command is None:
                continue
            if not (self.lockstep and self._gated):
                self._refuse(STEER_TOPIC, "pause, step and speed need a lockstep run on virtual time "
                             "(this run is realtime or on the host clock)", json.dumps(command))
                continue
            self._do(command)

    def _command(self, item: Any) -> dict[str, Any] | None:
        """A /hil/steer message or an app playback control as a steer command; None (after an
        error event) for a bad one."""
        if item[0] == "playback":
            _, what, speed, seek_ns = item
            if seek_ns is not None:
                return self._seek(int(seek_ns))
            return {"command": "pause"} if what == "pause" else {"command": "resume", "speed": speed}
        _, topic, raw = item
        if topic != STEER_TOPIC:
            self._refuse(topic, f"the bench takes messages on {INJECT_TOPIC} and {STEER_TOPIC} only", raw)
            return None
        try:
            msg = json.loads(raw)
        except ValueError as exc:
            self._refuse(topic, f"malformed JSON: {exc}", raw)
            return None
        problem = _steer_problem(msg)
        if problem:
            self._refuse(topic, problem, raw)
            return None
        return msg  # type: ignore[no-any-return]

    def _seek(self, seek_log_ns: int) -> dict[str, Any] | None:
        """The app's seek to log time ``seek_log_ns`` as steps to that sim time (None, after an
        event, for a seek that is not forward)."""
        target_ns = seek_log_ns - self.run_start_unix_ns
        ticks = seek_ticks(target_ns, self._t_ns, int(self.loop.tick_ns))
        if ticks < 1:
            self._refuse("playback", f"seek to t = {target_ns / 1e9:.3f} s: a live run cannot go back "
                         f"(now t = {self._t_ns / 1e9:.3f} s); open the run's MCAP to scrub", f"seek {seek_log_ns}")
            return None
        return {"command": "step", "ticks": ticks}

    def _do(self, command: dict[str, Any]) -> None:
        what = command["command"]
        if what == "pause":
            self.paused, self._steps = True, 0
        elif what == "step":
            self.paused, self._steps = True, self._steps + int(command.get("ticks", 1))
        else:
            self.paused, self._steps = False, 0
            self.speed = float(command.get("speed", self.speed))
        self._anchor = (self._t_ns, clock.monotonic_ns())
        self._event(what, {"speed": self.speed, "ticks": command.get("ticks", 0)})

    # -- faults --------------------------------------------------------------------------------------
    def _before_tick(self, k: int, t_ns: int) -> None:
        if self._injects:
            injects, self._injects = self._injects, []
            for raw in injects:
                self._inject(raw, t_ns)
        if self._steer and not self._gated:
            self._apply_steer()  # no gate runs: realtime or the host clock, refused there
        if self._prev_before is not None:
            self._prev_before(k, t_ns)

    def _inject(self, raw: bytes, t_ns: int) -> None:
        try:
            msg = json.loads(raw)
        except ValueError as exc:
            return self._refuse(INJECT_TOPIC, f"malformed JSON: {exc}", raw)
        if not isinstance(msg, dict) or not isinstance(msg.get("kind"), str):
            return self._refuse(INJECT_TOPIC, "kind: required, a fault kind (hil faults lists them)", raw)
        if "t_s" in msg:
            return self._refuse(INJECT_TOPIC, "t_s: not allowed (an injected fault starts at the next tick)", raw)
        schedule = self.runner.schedule
        params = {k: v for k, v in msg.items() if k not in ("kind", "duration_s")}
        try:
            handle = schedule.start_now(msg["kind"], t_ns, duration_s=msg.get("duration_s"), **params)
        except (ConfigError, TypeError, ValueError) as exc:
            return self._refuse(INJECT_TOPIC, str(exc), raw)
        self.log_event(t_ns, "live", "inject", {"handle": handle.id, "fault": msg})


def seek_ticks(target_ns: int, now_ns: int, tick_ns: int) -> int:
    """Ticks to step from sim time ``now_ns`` to reach ``target_ns`` (the first tick at or after
    it); 0 for a target at or before now."""
    if target_ns <= now_ns:
        return 0
    return -(-(target_ns - now_ns) // tick_ns)


def _steer_problem(msg: Any) -> str:
    if not isinstance(msg, dict):
        return "expected a JSON object such as {\"command\": \"pause\"}"
    if msg.get("command") not in ("pause", "resume", "step"):
        return f"command: must be pause, resume or step (got {msg.get('command')!r})"
    unknown = set(msg) - {"command", "speed", "ticks"}
    if unknown:
        return f"{sorted(unknown)[0]}: unknown key (command, speed, ticks)"
    speed = msg.get("speed", 0.0)
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not 0 <= speed < 1e6:
        return f"speed: a number >= 0 (x real time; 0 = as fast as possible), got {speed!r}"
    ticks = msg.get("ticks", 1)
    if isinstance(ticks, bool) or not isinstance(ticks, int) or ticks < 1:
        return f"ticks: an integer >= 1, got {ticks!r}"
    return ""


def attach_live(recorder: Any, loop: Any, runner: Any, logger: Any, *, lockstep: bool,
                note: Note = lambda text: None) -> Steering | None:
    """``run_flight_async``'s hook (``logger``: its RunLogger): announce the server's URL and start steering (None when
    the run has no live server)."""
    live = getattr(recorder, "live", None)
    if live is None or recorder.steer_fd < 0:
        return None
    url = f"ws://{live.host if ':' not in live.host else f'[{live.host}]'}:{recorder.live_port}"
    if live.announce is not None:
        live.announce(url)
    out = logger.out
    steering = Steering(recorder.take_steer_fd(), loop, runner, logger.event, lockstep=lockstep,
                        flush=out.flush if out is not None else lambda: None, note=note,
                        run_start_unix_ns=int(getattr(recorder, "run_start_unix_ns", 0)))
    steering.attach()
    return steering


__all__ = ["Steering", "attach_live", "seek_ticks"]
