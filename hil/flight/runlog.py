"""What a run records: device events, plant truth and timing -> MCAP topics and the trace.

The tick loop calls ``after_tick`` once per tick; devices push their events through
``on_event``; ports push raw bytes through their wire taps; the flight process pushes its
output lines through ``flight_line``. Everything goes to the recorder's queue (encoded and
written on its own thread) and, for signals the criteria use, to the trace (the streaming
criteria's feed, hil/analysis/trace_stream.py, and the whole-run trace when the caller keeps one).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from functools import partial
from typing import TYPE_CHECKING, Any

from emulators.base import DeviceEvent
from emulators.buspirate.events import BusPirateSpi
from emulators.maestro.device import TargetsSet
from emulators.mcp3204.device import Mcp3204Conversion
from emulators.xsens.events import CommandHandled, SampleSent
from hil import clock
from hil.flight.messages import (
    RAD2DEG,
    adc_payload,
    esc_output,
    jsonable,
    pose_payload,
    tf_payload,
    truth_payload,
)
from hil.flight.telemetry import TelemetryDecoder
from hil.transport.base import WireRecord

if TYPE_CHECKING:
    from hil.flight.tickloop import EndReason
    from hil.analysis.criteria import CriterionResult
    from hil.flight.devices import DeviceSet
    from hil.record import Recorder
    from hil.record.process import ProcessRecorder
    from hil.config.rig import Rig
    from hil.analysis.trace_stream import TraceSink
    from hil.transport.base import Port

#: events whose whole content is already on the wire tap (raw bytes per port)
_WIRE_ONLY_EVENTS = (BusPirateSpi, CommandHandled)
_LOGFMT_LEVEL = re.compile(r"\blevel=(\w+)")
#: a telemetry frame's own sample time is trusted when at most this much before its arrival
#: (the trace stream's delay line must be longer: hil/analysis/trace_stream.py)
STAMP_MAX_AGE_NS = 1_000_000_000
_FOXGLOVE_LEVEL = {"DEBUG": 1, "INFO": 2, "WARN": 3, "WARNING": 3, "ERROR": 4, "FATAL": 5, "CRITICAL": 5}


class RunLogger:
    """Recording and tracing of one run."""

    def __init__(
        self,
        recorder: Recorder | ProcessRecorder | None,
        trace: TraceSink,
        devices: DeviceSet,
        ports: Mapping[str, Port],
        rig: Rig,
        run_start_unix_ns: int = 0,
    ) -> None:
        self.rec = recorder
        #: everything recorded during a tick goes out with one queue put (after_tick)
        self.out = recorder.batch() if recorder is not None else None
        self.run_start_unix_ns = run_start_unix_ns
        self.trace = trace
        self.devices = devices
        self.rig = rig
        self.ports = ports
        self.truth_divider = rig.record.truth_divider
        self.pose_divider = rig.record.pose_divider
        self.counters_divider = rig.record.counters_divider
        self.progress: Callable[[int], None] | None = None
        self.progress_divider = 40
        self.fc_lines = 0
        self.telemetry = TelemetryDecoder()
        self._last_cmd_us: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
        self._adc: list[Mcp3204Conversion] = []  # this tick's conversions
        trace.define(
            "truth",
            {
                "roll_deg": 1, "pitch_deg": 1, "yaw_deg": 1, "h_m": 1, "x_m": 1, "y_m": 1, "vz_mps": 1,
                "omega_B_degps": 3, "rotor_omega_radps": 4, "battery_V": 1, "mass_kg": 1, "on_ground": 1,
            },
        )
        trace.define("esc", {"cmd_us": 4, "throttle": 4, "armed": 4})
        #: bench-side counters at each tick: ADC conversions the emulated ADC served since boot
        #: (a driver that stopped reading, or never gets past the bridge, serves none), and the
        #: bytes the IMU's line lost on their way to the flight code (wire faults on port imu:
        #: what went in and did not come out, held bytes included while held)
        trace.define("dev", {"adc_conversions": 1, "imu_bytes_lost": 1})
        self.adc_conversions = 0
        #: each wire fault ever on port imu (kept: it leaves the port when it ends) -> bytes lost
        self._imu_lost: dict[int, tuple[object, int]] = {}
        devices.event_sinks.append(self.on_event)
        if recorder is not None:
            for port in ports.values():
                port.taps.append(self._wire)
        if "telemetry" in ports:  # recorded or not, the criteria read the telemetry (tm.*)
            ports["telemetry"].taps.append(self._telemetry_wire)

    # -- sources ----------------------------------------------------------------------------------
    def _wire(self, rec: WireRecord) -> None:
        assert self.out is not None
        self.out.log_wire(rec.port, rec.direction.value, rec.t_ns, rec.t_host_ns, rec.data)

    def _telemetry_wire(self, rec: WireRecord) -> None:
        if rec.direction.value == "rx":
            for t_frame in self.telemetry.feed(rec.data):
                self._telemetry(rec.t_ns, rec.t_host_ns, t_frame)

    def _telemetry(self, t_ns: int, t_host_ns: int, frame: dict[str, Any]) -> None:
        # In the trace, a frame's values are stamped with the sim time of the IMU sample they
        # belong to (``t_s``: sensor time since the first sample, which is sim time 0), not
        # with their arrival over the radio: criteria compare them with truth at sample time.
        # A stamp that is not plausible (wrapped, or later than arrival) falls back.
        t_sample = frame.get("t_s")
        t_trace = t_ns
        if isinstance(t_sample, float):
            t_sample_ns = round(t_sample * 1e9)
            if 0 <= t_ns - t_sample_ns < STAMP_MAX_AGE_NS:
                t_trace = t_sample_ns
        for key, value in frame.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                self.trace.point(f"tm.{key}", t_trace, value)
        tau = frame.get("tau_applied_Nm")
        if isinstance(tau, list) and len(tau) == 3:
            # the torques the mixer produced (control activity in N m)
            for axis, value in zip(("roll", "pitch", "yaw"), tau, strict=True):
                self.trace.point(f"tm.tau_{axis}_Nm", t_trace, value)
        if self.out is not None:
            self.out.log("/fc/telemetry", t_ns, frame, t_host_ns)

    def on_event(self, port: str, ev: DeviceEvent) -> None:
        # Hot event types (several per tick) are turned into payloads by hand; the generic
        # dataclass walk is for the rare ones.
        if isinstance(ev, TargetsSet):
            targets = ev.targets_qus
            first = ev.first_channel
            cmd = list(self._last_cmd_us)
            for i, q in enumerate(targets):
                if 0 <= first + i < 4:
                    cmd[first + i] = q / 4.0
            self._last_cmd_us = tuple(cmd)
            if self.out is not None:
                self.out.log("/hil/esc/command", ev.t_ns, {"t_ns": ev.t_ns, "targets_us": cmd}, clock.monotonic_ns())
            return
        if isinstance(ev, Mcp3204Conversion):
            self.adc_conversions += 1
        rec = self.out
        if rec is None or isinstance(ev, _WIRE_ONLY_EVENTS):
            return
        t_host = clock.monotonic_ns()
        if isinstance(ev, SampleSent):
            sample = {
                "t_ns": ev.t_ns,
                "packet_counter": ev.packet_counter,
                "sample_time_fine": ev.sample_time_fine,
                "euler_deg": ev.euler_deg,
                "rate_radps": ev.rate_radps,
                "acc_mps2": ev.acc_mps2,
                "nbytes": ev.nbytes,
            }
            # items the configured output does not carry are left out, not null
            rec.log("/hil/imu/sample", ev.t_ns, {k: v for k, v in sample.items() if v is not None}, t_host)
        elif isinstance(ev, Mcp3204Conversion):
            # one message per tick holds the tick's conversions (after_tick): a message per
            # conversion cost more in record overhead than the conversion itself
            self._adc.append(ev)
        else:
            detail = jsonable(ev)
            detail.pop("t_ns", None)
            rec.log("/hil/events", max(ev.t_ns, 0),
                    {"t_ns": ev.t_ns, "kind": f"device.{port}", "name": type(ev).__name__, "detail": detail}, t_host)

    def flight_line(self, stream: str, line: str) -> None:
        self.fc_lines += 1
        if self.out is None:
            return
        m = _LOGFMT_LEVEL.search(line)
        level = _FOXGLOVE_LEVEL.get(m.group(1).upper(), 2) if m else (4 if stream == "stderr" else 2)
        t_ns = max(self.devices.t_ns, 0)
        self.out.log(
            "/fc/log",
            t_ns,
            {"message": line, "level": level, "name": f"flightcode.{stream}", "file": "", "line": 0},
            clock.monotonic_ns(),
        )

    def event(self, t_ns: int, kind: str, name: str, detail: dict[str, Any]) -> None:
        if self.out is not None:
            self.out.log(
                "/hil/events",
                max(t_ns, 0),
                {"t_ns": t_ns, "kind": kind, "name": name, "detail": jsonable(detail)},
                clock.monotonic_ns(),
            )

    # -- per tick -------------------------------------------------------------------------------------
    def _imu_bytes_lost(self) -> int:
        filters = self.devices.wire_filters.get("imu")
        if filters:
            for f in filters:
                counters = getattr(f, "counters", None)
                if counters is not None:
                    self._imu_lost[id(f)] = (f, counters["tx_bytes_in"] - counters["tx_bytes_out"])
        return sum(n for _, n in self._imu_lost.values())

    def after_tick(self, k: int, t_ns: int) -> None:
        d = self.devices
        st = d.plant.state
        roll, pitch, yaw = st.euler_rpy_rad
        om = st.omega_B_radps
        self.trace.row(
            "truth",
            t_ns,
            (
                roll * RAD2DEG, pitch * RAD2DEG, yaw * RAD2DEG, st.h_m, st.p_N_m[0], st.p_N_m[1], -st.v_N_mps[2],
                om[0] * RAD2DEG, om[1] * RAD2DEG, om[2] * RAD2DEG, *st.rotor_omega_radps,
                st.battery_V, st.mass_kg, 1.0 if st.on_ground else 0.0,
            ),
        )
        armed = tuple(1.0 if e.armed else 0.0 for e in d.escs)
        self.trace.row("esc", t_ns, (*self._last_cmd_us, *d.throttle, *armed))
        self.trace.row("dev", t_ns, (float(self.adc_conversions), float(self._imu_bytes_lost())))
        rec = self.out
        t_host = clock.monotonic_ns()
        if d.rc_frames:
            for frame in d.rc_frames:
                pulses = list(frame.pulses_us[:8]) + [0] * max(0, 8 - len(frame.pulses_us))  # type: ignore[attr-defined]
                self.trace.point("rc.throttle_us", frame.t_ns, pulses[2])  # type: ignore[attr-defined]
                if rec is not None:
                    rec.log("/hil/rc/pulses", frame.t_ns, {"t_ns": frame.t_ns, "pulse_us": pulses, "present": True}, t_host)  # type: ignore[attr-defined]
            d.rc_frames.clear()
        if d.latency:
            # taken every tick, recorded or not: the list holds one tick's samples, never the
            # run's (the run's figures are streamed in d.latency_stats)
            pending, d.latency = d.latency, []
            for lat in pending if rec is not None else ():  # (rec is not None inside)
                arrival = lat.t_arrival_host_ns
                host_us = (arrival - lat.t_emit_host_ns) / 1e3 if arrival is not None else -1.0
                if lat.t_arrival_ns is not None:
                    latency_us = (lat.t_arrival_ns - lat.t_ns) / 1e3
                else:
                    latency_us = host_us if lat.fc_cpu_ns is None else -1.0
                rec.log(  # type: ignore[union-attr]
                    "/hil/timing/tick",
                    lat.t_ns,
                    {
                        "k": lat.t_ns // self.rig.tick_ns,
                        "t_ns": lat.t_ns,
                        "imu_emit_host_ns": lat.t_emit_host_ns,
                        "esc_arrival_host_ns": arrival if arrival is not None else -1,
                        "latency_us": latency_us,
                        "host_latency_us": host_us,
                        "fc_cpu_us": lat.fc_cpu_ns / 1e3 if lat.fc_cpu_ns is not None else -1.0,
                        "lateness_us": lat.lateness_ns / 1e3 if lat.lateness_ns is not None else -1.0,
                        "miss": arrival is None,
                    },
                    t_host,
                )
        if rec is not None:
            # PlantState is immutable: its payloads are built on the writer thread
            if k % self.truth_divider == 0:
                rec.log("/sim/truth", t_ns, partial(truth_payload, t_ns, st), t_host)
                rec.log("/hil/esc/output", t_ns, partial(esc_output, t_ns, d.throttle, armed), t_host)
            if k % self.pose_divider == 0:
                stamp = divmod(self.run_start_unix_ns + t_ns, 1_000_000_000)
                rec.log("/tf", t_ns, partial(tf_payload, stamp, st), t_host)
                rec.log("/sim/pose", t_ns, partial(pose_payload, stamp, st), t_host)
            if self._adc:
                rec.log("/hil/adc/conversion", self._adc[0].t_ns, adc_payload(self._adc), t_host)
                self._adc = []
            if k % self.counters_divider == 0:
                rec.log("/hil/device/counters", t_ns, {"t_ns": t_ns, "counters": self.counters()}, t_host)
            rec.flush()
        if self.progress is not None and k % self.progress_divider == 0:
            self.progress(t_ns)

    # -- end ----------------------------------------------------------------------------------------------
    def counters(self) -> dict[str, dict[str, int]]:
        out: dict[str, dict[str, int]] = {}
        for name, device in self.devices.by_port.items():
            out[name] = {k: int(v) for k, v in device.counters.items()}
        for name, port in self.ports.items():
            s = port.stats
            out[f"port.{name}"] = {
                "bytes_tx": s.bytes_tx, "bytes_rx": s.bytes_rx, "overflow_bytes": s.overflow_bytes,
                "opens": s.opens, "line_changes": s.line_changes, "delivery_timeouts": s.delivery_timeouts,
            }
        return out

    def finish(
        self,
        end: EndReason,
        criteria: list[CriterionResult],
        timing: dict[str, float],
        message: str,
        returncode: int | None,
    ) -> None:
        if self.out is None:
            return
        t_ns = max(self.devices.t_ns, 0)
        self.out.log(
            "/hil/verdict",
            t_ns,
            {
                "end_reason": end.value,
                "passed": end.value == "completed" and all(c.passed for c in criteria),
                "message": message,
                "flight_returncode": -1 if returncode is None else returncode,
                "criteria": [jsonable(c) for c in criteria],
                "timing": jsonable(timing),
            },
            clock.monotonic_ns(),
        )
        self.out.flush()
