"""The devices of a board run: the rig's plant and device models (a
:class:`~hil.flight.devices.DeviceSet`) wired to the emulated LPC2148's pins
(:class:`~hil.flight.board_wiring.BoardWiring`) instead of to a flight process's ptys.

The DeviceSet is the same one a process run has, so everything that acts on it acts on a
board run alike: the faults (sensor, device, plant and link faults on the models; wire faults
on the imu and telemetry ports' bytes, which are the UARTs' bytes here), the recording (event
sinks, wire taps) and the criteria. What differs is how the devices meet the flight code:

* the XSENS and the XBee reach UART0 and UART1 through
  :class:`~hil.flight.board_port.BoardPort`; the ground XBee keeps its pty;
* the MCP3204 answers SPI0 (its conversions go to the event sinks as the ``adc`` port's);
* the PPM generator's edges go to CAP1.0, its frames to the recording;
* the ESC models take their inputs from the PWM and match-output pins; their widths at each
  tick, when they changed, go to the event sinks as the esc port's ``TargetsSet`` (the
  recording's ``/hil/esc/command``, the criteria's ``esc.cmd_us``).

The Bus Pirate, the capture front-end and the Maestro of the DeviceSet have no wire on a
board run and stay idle.
"""

from __future__ import annotations

from collections.abc import Callable

from emulators.base import DeviceEvent
from emulators.maestro.device import TargetsSet
from emulators.xsens.events import SampleSent
from hil.analysis.timing_stream import LatencySample, LatencyStats
from hil.flight.board_wiring import BoardWiring
from hil.flight.devices import DeviceSet

_SPCR_MSTR = 0x20


class BoardDevices:
    """:class:`~hil.flight.tick.TickDevices` of a board run (see the module docstring)."""

    def __init__(self, devices: DeviceSet, wiring: BoardWiring) -> None:
        self.devices = devices
        self.wiring = wiring
        self.on_esc_command: Callable[[int, int], None] = lambda t_host_ns, t_ns: None
        self.sample_counter = -1  #: the packet counter of the last sample the XSENS sent
        self._commanded: tuple[float, ...] = ()
        devices.event_sinks.append(self._on_event)

    def _on_event(self, port: str, ev: DeviceEvent) -> None:
        if isinstance(ev, SampleSent) and ev.packet_counter is not None:
            self.sample_counter = ev.packet_counter

    @property
    def t_ns(self) -> int:
        return self.devices.t_ns

    @t_ns.setter
    def t_ns(self, value: int) -> None:
        self.devices.t_ns = value

    @property
    def latency_stats(self) -> LatencyStats:
        return self.devices.latency_stats

    # -- the firmware's time ---------------------------------------------------------------------
    def advance_to(self, t_ns: int) -> None:
        """Run the firmware to ``t_ns`` with the PPM edges due by then on its capture pin, then
        hand the ADC's conversions to the event sinks."""
        d = self.devices
        edges = d.ppm.edges_until(t_ns) if t_ns >= 0 else []  # the receiver starts with sim time
        frames = d.ppm.take_frames()
        if frames:
            d.rc_frames.extend(frames)
        if edges:
            self.wiring.feed_edges(edges)
        self.wiring.run_to(t_ns)
        events = d.mcp.take_events()
        if events:
            for sink in d.event_sinks:
                for ev in events:
                    sink("adc", ev)

    # -- TickDevices ----------------------------------------------------------------------------
    def advance_boot(self, t_ns: int) -> None:
        self.devices.advance_boot(t_ns)

    def unconfigured(self) -> dict[str, str]:
        missing: dict[str, str] = {}
        for name in self.devices.rig.flight.required_devices:
            ok, why = self.configured(name)
            if not ok:
                missing[name] = why
        return missing

    def configured(self, name: str) -> tuple[bool, str]:
        """A device the firmware has set up: the XSENS measuring (the firmware's own
        GoToMeasurement), SPI0 a master on its pins, the ESCs given pulses."""
        bus = self.wiring.bus
        if name == "adc":
            ok = bool(bus.spi0.spcr & _SPCR_MSTR) and all(bus.pinsel.selected(f) for f in ("SCK0", "MISO0", "MOSI0"))
            return ok, "SPI0 not set up as a master on P0.4-P0.6 (the firmware's hal_spi_start)"
        if name == "esc":
            ok = any(w > 0 for w in self.wiring.escs.width_us)
            return ok, "no ESC output gives pulses"
        return self.devices.configured(name)

    def emit_rc_early(self, t_ns: int) -> None:
        """Nothing to write: the PPM edges reached the capture pin as the firmware ran."""

    async def confirm_rc(self) -> None:
        return None

    def actuate_and_step(self, t_ns: int) -> None:
        d = self.devices
        d.t_ns = t_ns
        escs = d.escs
        pins = self.wiring.escs
        d.throttle = pins.drive(t_ns, lambda i, t, w: escs[i].update(t, w))  # type: ignore[assignment]
        widths = pins.applied_us
        if widths != self._commanded:  # the criteria's esc.cmd_us: the widths on the ESC pins
            self._commanded = widths
            ev = TargetsSet(t_ns, 0, tuple(round(w * 4) for w in widths))
            for sink in d.event_sinks:
                sink("esc", ev)
        if t_ns > d.plant.t_ns:
            d.plant.step(t_ns, d.throttle)
        d.sensors = d.plant.sensors()

    def latch_analog(self, t_ns: int) -> None:
        self.devices.latch_analog(t_ns)

    def emit_imu(self, t_ns: int) -> tuple[bool, bool]:
        self.devices.t_ns = t_ns
        return self.devices.emit_imu(t_ns)

    def newest_sample_unread(self) -> bool:
        return False

    def note_latency(self, sample: LatencySample) -> None:
        self.devices.note_latency(sample)

    def finish_tick(self, t_ns: int) -> None:
        self.devices.finish_tick(t_ns)
