"""All emulated devices of a rig, the plant, and their wiring to ports.

``DeviceSet`` owns the physical world (plant), every device model, and the glue between
them: plant outputs become device inputs, device outputs (ESC throttles) become plant
inputs. It does no waiting; the tick loop (``hil/flight/tickloop.py``) decides when things happen.
Ports are attached by name; bytes from a port go to its device's ``receive`` and the
device's replies are written back at once (ADC transactions are answered from the latch
within the tick).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from emulators.analog.frontend import AnalogFrontEnd
from emulators.base import ByteDevice, DeviceEvent
from emulators.buspirate.device import BusPirate
from emulators.esc.esc import Esc
from emulators.maestro.device import Maestro, TargetsSet
from emulators.mcp3204.device import Mcp3204
from emulators.rc.capture import CaptureFrontEnd
from emulators.rc.ppm import PpmGenerator, Sticks
from emulators.rc.sbus import SbusConverter
from emulators.xbee.link import RadioLink
from emulators.xbee.module import XBeeModule
from emulators.xsens.defs import MID
from emulators.xsens.device import MtiDevice
from emulators.xsens.events import CommandHandled, SampleSent
from hil import clock
from hil.plant.plant import Plant
from hil.plant.records import Quat, Vec3
from hil.config.rig import Rig
from hil.analysis.timing_stream import LatencySample, LatencyStats
from hil.transport.base import LineSettings, Port

#: Names of the RNG streams, in spawn order (adding one at the end keeps the others).
RNG_STREAMS = ("plant", "imu", "analog", "ppm", "esc", "xbee_vehicle", "xbee_ground", "link", "faults", "vibration")

EventSink = Callable[[str, DeviceEvent], None]
#: ``(t_ns, q_NS, omega_S_radps, f_S_mps2) -> (q_NS, omega_S_radps, f_S_mps2)``: sensor frame S
MotionTransform = Callable[[int, Quat, Vec3, Vec3], tuple[Quat, Vec3, Vec3]]


class WireFilter(Protocol):
    """A fault acting on the bytes of one port (both directions)."""

    def tx(self, data: bytes, t_ns: int) -> bytes: ...
    def rx(self, data: bytes, t_ns: int) -> bytes: ...
    def poll(self, t_ns: int) -> bytes: ...


def spawn_rngs(seed: int) -> dict[str, np.random.Generator]:
    """One Generator per component from the run seed (numpy SeedSequence.spawn)."""
    children = np.random.SeedSequence(seed).spawn(len(RNG_STREAMS))
    return {name: np.random.default_rng(s) for name, s in zip(RNG_STREAMS, children, strict=True)}


class DeviceSet:
    """Plant + emulators for one run."""

    def __init__(self, rig: Rig, *, seed: int, stick_script: Sticks, with_spidriver: bool = False) -> None:
        self.rig = rig
        self.rngs = spawn_rngs(seed)
        self.plant = Plant(rig.plant, self.rngs["plant"], vibration_rng=self.rngs["vibration"])
        self.imu = MtiDevice(rig.imu, self.rngs["imu"])
        self.analog = AnalogFrontEnd(rig.analog, self.rngs["analog"])
        self.mcp = Mcp3204(rig.adc.mcp3204, self.analog.volts)
        self.adc = BusPirate(rig.adc.buspirate, self.mcp)
        self.spidriver: ByteDevice | None = None
        if with_spidriver:
            from emulators.spidriver.device import SpiDriver

            self.spidriver = SpiDriver(rig.adc.spidriver, Mcp3204(rig.adc.mcp3204, self.analog.volts))
        self.sticks = stick_script
        self.ppm = PpmGenerator(rig.rc.ppm, self.rngs["ppm"], stick_script)
        self.rc: CaptureFrontEnd | SbusConverter = (
            CaptureFrontEnd(rig.rc.capture) if rig.rc.frontend == "capture" else SbusConverter(rig.rc.sbus)
        )
        self.maestro = Maestro(rig.esc.maestro)
        esc_rngs = self.rngs["esc"].spawn(4)
        self.escs = [Esc(rig.esc.esc, r) for r in esc_rngs]
        self.xbee_vehicle = XBeeModule(rig.telemetry.vehicle, self.rngs["xbee_vehicle"], name="telemetry")
        self.xbee_ground = XBeeModule(rig.telemetry.ground, self.rngs["xbee_ground"], name="ground")
        self.link = RadioLink(rig.telemetry.link, self.rngs["link"])
        self.link.attach(self.xbee_vehicle)
        self.link.attach(self.xbee_ground)

        self.by_port: dict[str, ByteDevice] = {
            "imu": self.imu,
            "adc": self.adc,
            "rc": self.rc,
            "esc": self.maestro,
            "telemetry": self.xbee_vehicle,
            "ground": self.xbee_ground,
        }
        if self.spidriver is not None:
            self.by_port["adc-spidriver"] = self.spidriver
        self.ports: dict[str, Port] = {}
        self.t_ns = 0
        self.throttle: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self.sensors = self.plant.sensors()
        #: boot ends when the flight code itself has put the XSENS into measurement
        self.imu_started_by_host = False
        #: called with (host ns, sim ns) for every Maestro command that sets targets
        self.on_esc_command: Callable[[int, int], None] = lambda t_host_ns, t_ns: None
        self.event_sinks: list[EventSink] = []
        #: port -> wire-fault filters (hil/faults.py): ``tx(data, t_ns) -> bytes`` on the way
        #: to the client, ``rx(data, t_ns) -> bytes`` on the way to the device,
        #: ``poll(t_ns) -> bytes`` releases bytes held back (delay/jitter).
        self.wire_filters: dict[str, list[WireFilter]] = {}
        #: samples not yet taken by the run logger (it empties this every tick); the figures of
        #: every sample are in latency_stats, streamed (bounded memory however long the flight)
        self.latency: list[LatencySample] = []
        self.latency_stats = LatencyStats(rig.tick_ns)
        self._rc_want: int | None = None
        #: the IMU port's accepted byte count where the newest sample began (-1: none yet)
        self._imu_mark = -1
        #: timing stress: hold every ADC bridge reply back this long (wall ns; hil/flight/stress.py)
        self.adc_reply_delay_ns = 0
        #: IMU sensor faults: ``(t_ns, q_NS, omega_S_radps, f_S_mps2) -> the same, transformed``,
        #: applied to the motion handed to the XSENS model (None: the true motion)
        self.imu_motion: MotionTransform | None = None
        #: PPM frames generated since the run logger last took them (PpmFrame records)
        self.rc_frames: list[object] = []

    # -- wiring ---------------------------------------------------------------------------------
    def attach(self, ports: dict[str, Port]) -> None:
        """Connect each port to its device; the port's sim clock is this set's ``t_ns``."""
        for name, port in ports.items():
            device = self.by_port[name]
            self.ports[name] = port
            port.sim_time = self._now
            port.on_data = self._receiver(name, device, port)
            port.on_line = self._line_receiver(device)

    def _now(self) -> int:
        return self.t_ns

    def _receiver(self, name: str, device: ByteDevice, port: Port) -> Callable[[bytes, int], None]:
        is_esc = device is self.maestro
        is_adc = device is self.adc

        def on_data(data: bytes, t_ns: int) -> None:
            filters = self.wire_filters.get(name)
            if filters:
                for f in filters:
                    data = f.rx(data, t_ns)
                if not data:
                    return
            device.receive(data, t_ns)
            out = device.take_output()
            if out:
                if is_adc and self.adc_reply_delay_ns:
                    clock.sleep_until_ns(clock.monotonic_ns() + self.adc_reply_delay_ns)  # timing stress
                self.write(name, out)
            events = device.take_events()
            if is_adc:
                events += self.mcp.take_events()
            if events:
                self._dispatch(name, events)
                if is_esc and any(isinstance(e, TargetsSet) for e in events):
                    self.on_esc_command(clock.monotonic_ns(), t_ns)

        return on_data

    def _line_receiver(self, device: ByteDevice) -> Callable[[LineSettings], None]:
        def on_line(settings: LineSettings) -> None:
            if settings.baud is not None:
                device.line_settings_changed(settings.baud, self.t_ns)

        return on_line

    def _dispatch(self, port: str, events: list[DeviceEvent]) -> None:
        if port == "imu" and not self.imu_started_by_host:
            for ev in events:
                if isinstance(ev, CommandHandled) and ev.mid == MID.GOTO_MEASUREMENT:
                    self.imu_started_by_host = True
        for sink in self.event_sinks:
            for ev in events:
                sink(port, ev)

    def _filtered(self, name: str, data: bytes, t_ns: int) -> bytes:
        filters = self.wire_filters.get(name)
        if filters:
            for f in filters:
                data = f.tx(data, t_ns)
        return data

    def write(self, name: str, data: bytes) -> int:
        """Device -> client bytes, through the port's wire-fault filters; returns bytes written."""
        data = self._filtered(name, data, self.t_ns)
        port = self.ports.get(name)
        if data and port is not None:
            port.write(data)
            return len(data)
        return 0

    def _release_held(self, t_ns: int) -> None:
        """Bytes that wire faults held back (delay, jitter) and whose time has come."""
        for name, filters in self.wire_filters.items():
            for i, f in enumerate(filters):
                late = f.poll(t_ns)
                for g in filters[i + 1 :]:
                    late = g.tx(late, t_ns) if late else late
                port = self.ports.get(name)
                if late and port is not None:
                    port.write(late)

    def _flush(self, name: str) -> None:
        device = self.by_port[name]
        out = device.take_output()
        if out:
            self.write(name, out)
        events = device.take_events()
        if events:
            self._dispatch(name, events)

    # -- boot -----------------------------------------------------------------------------------
    def advance_boot(self, t_ns: int) -> None:
        """Boot phase (t_ns < 0): protocol timers run, nothing streams."""
        self.t_ns = t_ns
        for name, device in self.by_port.items():
            if device is self.rc:
                continue  # the receiver starts with sim time
            device.advance(t_ns)
            self._flush(name)

    def unconfigured(self) -> dict[str, str]:
        """Required devices the flight code has not configured yet -> why."""
        missing: dict[str, str] = {}
        for name in self.rig.flight.required_devices:
            ok, why = self.configured(name)
            if not ok:
                missing[name] = why
        return missing

    def configured(self, name: str) -> tuple[bool, str]:
        if name == "imu":
            return (
                self.imu_started_by_host and self.imu.measuring,
                f"XSENS in {self.imu.state.name} state, waiting for the flight code's GoToMeasurement",
            )
        if name == "adc":
            mode = self.adc.mode
            ok = mode.name.upper().startswith("SPI")
            return ok, f"Bus Pirate in {mode.name} mode, waiting for binary SPI mode (20x00, 01)"
        if name == "esc":
            ok = self.maestro.counters.get("commands", 0) > 0
            return ok, "no command received by the Maestro"
        return True, ""

    # -- the tick -------------------------------------------------------------------------------
    def actuate_and_step(self, t_ns: int) -> None:
        self.t_ns = t_ns
        self.maestro.advance(t_ns)
        m, e = self.maestro, self.escs
        self.throttle = (
            e[0].update(t_ns, m.pulse_us(0, t_ns)), e[1].update(t_ns, m.pulse_us(1, t_ns)),
            e[2].update(t_ns, m.pulse_us(2, t_ns)), e[3].update(t_ns, m.pulse_us(3, t_ns)),
        )
        if t_ns > self.plant.t_ns:
            self.plant.step(t_ns, self.throttle)
        self.sensors = self.plant.sensors()

    def emit_rc_early(self, t_ns: int) -> None:
        """Write the RC bytes due by ``t_ns`` without waiting for delivery.

        The PPM train is a function of the stick script only, so this can run first in the
        tick; the kernel moves the bytes while the plant steps, and :meth:`confirm_rc`
        (before the IMU sample) usually finds them delivered already."""
        self.t_ns = t_ns
        edges = self.ppm.edges_until(t_ns)
        frames = self.ppm.take_frames()
        if frames:
            self.rc_frames.extend(frames)
        if edges:
            self.rc.feed_edges(edges)
        self.rc.advance(t_ns)
        out = self._filtered("rc", self.rc.take_output(), t_ns)
        port = self.ports.get("rc")
        self._rc_want = port.write_tracked(out) if out and port is not None else None
        events = self.rc.take_events()
        if events:
            self._dispatch("rc", events)

    def newest_sample_unread(self) -> bool:
        """The flight code has not begun reading the newest IMU sample (False where the bench
        cannot see its end of the port). A command arriving now answers an older sample: the
        flight code reads a sample before it answers it. Judged from where the sample's bytes
        began, so bytes after it (a fault's extra bytes, a duplicate) do not count."""
        port = self.ports.get("imu")
        if port is None or self._imu_mark < 0:
            return False
        consumed = port.client_consumed()
        return consumed is not None and consumed <= self._imu_mark

    async def confirm_rc(self) -> None:
        """Wait until the RC bytes written this tick are readable by the flight code."""
        port = self.ports.get("rc")
        if self._rc_want is not None and port is not None:
            await port.confirm(self._rc_want)
        self._rc_want = None

    async def emit_rc(self, t_ns: int) -> None:
        """Write the RC bytes due by ``t_ns`` and wait until they are readable (both steps)."""
        self.emit_rc_early(t_ns)
        await self.confirm_rc()

    def latch_analog(self, t_ns: int) -> None:
        s = self.sensors
        self.analog.update(t_ns, s.p_static_Pa, s.f_acc_B_mps2, s.air_T_C)
        self.analog.set_vibration(s.t_ns, s.vib_f_acc_B)

    def emit_imu(self, t_ns: int) -> tuple[bool, bool]:
        """Emit IMU sample(s) due at t_ns; returns (emitted, due).

        ``due`` is True when the device is measuring and t_ns is on its output grid even
        if a fault silenced it: the barrier is still awaited so the flight code's IMU-loss
        watchdog shows up in sim time (DESIGN.md §4).
        """
        s = self.sensors
        w, f = s.omega_S_radps, s.f_S_mps2
        if s.vib_f_S:  # rotor vibration as this XSENS senses it at the sample instant, then any IMU fault
            dv_f, dv_w = self.imu.vibration_S(s.vib_f_S, s.vib_omega_S, (t_ns - s.t_ns) * 1e-9)
            f = (f[0] + dv_f[0], f[1] + dv_f[1], f[2] + dv_f[2])
            w = (w[0] + dv_w[0], w[1] + dv_w[1], w[2] + dv_w[2])
        q = s.q_NS
        if self.imu_motion is not None:  # IMU sensor faults (hil/faults/env.py), before the device's own errors
            q, w, f = self.imu_motion(t_ns, q, w, f)
        self.imu.set_motion(q, w, f)
        self.imu.advance(t_ns)
        out = self.imu.take_output()
        events = self.imu.take_events()
        emitted = any(isinstance(e, SampleSent) for e in events)
        if out:
            port = self.ports.get("imu")
            if emitted and port is not None:
                self._imu_mark = port.accepted_bytes()  # where the newest sample's bytes begin
            written = self.write("imu", out)
            emitted = emitted and written > 0
        if events:
            self._dispatch("imu", events)
        period = self.imu.output_period_ns
        due = bool(self.imu.measuring and period and t_ns % period == 0)
        return emitted, due

    def note_latency(self, sample: LatencySample) -> None:
        self.latency.append(sample)
        self.latency_stats.add(sample)

    def finish_tick(self, t_ns: int) -> None:
        """Everything after the barrier: the radio link, slow devices, their outputs."""
        if self.wire_filters:
            self._release_held(t_ns)
        self.link.advance(t_ns)
        link_events = self.link.take_events()
        if link_events:
            self._dispatch("telemetry", link_events)
        for esc in self.escs:
            esc_events = esc.take_events()
            if esc_events:
                self._dispatch("esc", esc_events)
        for name in ("telemetry", "ground", "esc", "adc"):
            self.by_port[name].advance(t_ns)
            self._flush(name)
        if self.spidriver is not None:
            self._flush("adc-spidriver")
