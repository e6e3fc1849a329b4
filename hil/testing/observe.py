"""What a test sees of its bench: the device events and telemetry it keeps while the run goes
(plant truth, IMU sample, ESC command, decoded telemetry, counters) and, after the run, its
result, recorded topics, timing and trace signals. Frames and units as docs/pytest-plugin.md."""

from __future__ import annotations

import math
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

# The event types are the emulators' own (compiled) records: a bench's devices load them
# anyway, and the plugin imports this module only when a test starts a bench.
from emulators.maestro.device import TargetsSet
from emulators.xsens.events import SampleSent
from hil.testing.records import S, EscCommand, Truth
from hil.testing.state import BenchState
from hil.transport.base import Direction

if TYPE_CHECKING:
    from emulators.base import DeviceEvent
    from hil.analysis.timing import TimingReport
    from hil.analysis.trace import Trace
    from hil.flight.process import FlightProcess
    from hil.flight.run import RunResult
    from hil.transport.base import WireRecord

RAD2DEG = 180.0 / math.pi


class BenchObserver(BenchState):
    """The bench's view of the run: fed by the devices' event sink and the telemetry wire tap."""

    # -- fed from the tick path (never raise) -------------------------------------------------------
    def _on_event(self, port: str, ev: DeviceEvent) -> None:
        self._events[type(ev).__name__] = ev  # by type name: last_event("EscDisarmed")
        if isinstance(ev, SampleSent):
            self._imu = ev
        elif isinstance(ev, TargetsSet):
            first = ev.first_channel
            for i, q in enumerate(ev.targets_qus):
                if 0 <= first + i < 4:
                    self._esc_us[first + i] = q / 4.0  # quarter-microseconds
            self._esc = EscCommand(ev.t_ns / S, (self._esc_us[0], self._esc_us[1], self._esc_us[2], self._esc_us[3]))

    def _on_telemetry_wire(self, rec: WireRecord) -> None:
        if rec.direction is Direction.RX:  # written by the flight code to its XBee
            for frame in self._decoder.feed(rec.data):
                self._telemetry = frame | {"rx_t_s": rec.t_ns / S}

    # -- live values ---------------------------------------------------------------------------------
    @property
    def truth(self) -> Truth:
        """Plant truth now (see :class:`Truth`)."""
        assert self.devices is not None, "the bench has not started"
        st = self.devices.plant.state
        r, p, y = st.euler_rpy_rad
        w = st.omega_B_radps
        return Truth(self.t_s, st.h_m, -st.v_N_mps[2], r * RAD2DEG, p * RAD2DEG, y * RAD2DEG, st.p_N_m,
                     st.v_N_mps, (w[0] * RAD2DEG, w[1] * RAD2DEG, w[2] * RAD2DEG),
                     st.rotor_omega_radps, bool(st.on_ground), st.battery_V, st)

    @property
    def imu_sample(self) -> SampleSent | None:
        """The last XSENS sample sent (emulators.xsens.events.SampleSent: euler_deg, rate_radps,
        acc_mps2 as on the wire), or None before the first."""
        return self._imu

    @property
    def esc_command(self) -> EscCommand | None:
        """The flight code's last ESC command (see :class:`EscCommand`), or None before the first."""
        return self._esc

    @property
    def esc_throttle(self) -> tuple[float, ...]:
        """The four ESC models' throttle outputs, 0..1."""
        assert self.devices is not None, "the bench has not started"
        return tuple(self.devices.throttle)

    @property
    def esc_armed(self) -> tuple[bool, ...]:
        assert self.devices is not None, "the bench has not started"
        return tuple(e.armed for e in self.devices.escs)

    @property
    def telemetry(self) -> dict[str, Any] | None:
        """The last telemetry frame the flight code sent, decoded (hil.flight.telemetry keys, plus
        ``rx_t_s``: sim time it reached the bench), or None before the first."""
        return self._telemetry

    @property
    def flight_mode(self) -> str | None:
        """The flight code's mode from its last telemetry frame ("DISARMED", "FLYING", ...)."""
        return None if self._telemetry is None else str(self._telemetry["mode_name"])

    @property
    def counters(self) -> dict[str, dict[str, int]]:
        """Device counters by port, and ``port.<name>`` byte/open/overflow counters."""
        assert self.devices is not None, "the bench has not started"
        out = {name: {k: int(v) for k, v in d.counters.items()} for name, d in self.devices.by_port.items()}
        for name, port in self.devices.ports.items():
            # fields, not vars(): the ports' records are compiled (no __dict__)
            out[f"port.{name}"] = {f.name: v for f in fields(port.stats)
                                   if isinstance(v := getattr(port.stats, f.name), int)}
        return out

    def last_event(self, name: str) -> DeviceEvent | None:
        """The last device event of this type name ("EscDisarmed", "SampleSent", ...)."""
        return self._events.get(name)

    @property
    def flight(self) -> FlightProcess | None:
        """The flight code's hil.flight.process.FlightProcess (pid, last_stderr, returncode)."""
        return None if self.runner is None else self.runner.flight

    # -- after the run -------------------------------------------------------------------------------
    @property
    def result(self) -> RunResult:
        """The run's hil.flight.run.RunResult (after :meth:`stop` / :meth:`finish`)."""
        task = self._require_task()
        if not task.done():
            raise RuntimeError("the run is still going: await bench.stop() or bench.finish() first")
        if task.cancelled():
            raise RuntimeError("the run's task was cancelled from outside the plugin: no result")
        return task.result()

    def record(self, topic: str) -> dict[str, Any]:
        """A recorded topic as columns (hil.record.read_topic: ``log_time_ns`` + one numpy
        array per field), after the run."""
        from hil.record import read_topic

        return read_topic(self._log(), topic)

    def timing(self, budget_us: float = 2500.0) -> TimingReport:
        """The loop timing report of the run (hil.analysis.timing.analyze_log), after the run."""
        from hil.analysis.timing import analyze_log

        return analyze_log(self._log(), budget_us)

    def signal(self, name: str) -> tuple[Any, Any]:
        """``(t_s, values)`` of a trace signal ("truth.h_m", "esc.cmd_us[2]", "tm.alt_est_m"), after the run."""
        trace: Trace | None = self.result.trace
        assert trace is not None
        return trace.signal(name)

    def _log(self) -> Path:
        path = self.result.log_path
        if path is None:
            raise RuntimeError("this run has no MCAP log")
        return path

    # -- failure reports -----------------------------------------------------------------------------
    def _state_text(self) -> str:
        tr = self.truth
        esc = self._esc.pulse_us if self._esc else None
        return (f"now h = {tr.h_m:.3f} m, roll {tr.roll_deg:.2f} deg, pitch {tr.pitch_deg:.2f} deg, "
                f"on_ground {tr.on_ground}, mode {self.flight_mode}, esc {esc}")

    def describe(self) -> str:
        """One paragraph for failure reports."""
        where = f"t = {self.t_s:.4f} s sim"
        if self._task is not None and self._task.done() and not self._task.cancelled() and not self._task.exception():
            r = self._task.result()
            where += f", ended: {r.end_reason.value} {r.message}"
        elif self.devices is not None:
            where += f", running; {self._state_text()}"
        lines = [f"rig {self.rig.name}, scenario {self.scenario.name}, seed {self.seed}: {where}"]
        lines += [f"event-loop stall of {s * 1e3:.0f} ms at t = {t:.3f} s" for t, s in self.stalls[:5]]
        if self.flight is not None and self.flight.last_stderr:
            lines += ["flight code stderr (last lines):", *("  " + s for s in list(self.flight.last_stderr)[-8:])]
        return "\n".join(lines)
