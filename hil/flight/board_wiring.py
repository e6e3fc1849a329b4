"""The emulated LPC2148 running the firmware, wired at its pins to the rig's device models.

:class:`BoardWiring` owns the core (hil/board), the peripheral models (emulators/lpc2148) and
the firmware image, and connects them as the vehicle's wiring does (the pin map of
firmware/hal/lpc2148/lpc2148.h):

| pins | device model | how |
|---|---|---|
| UART0 TXD0/RXD0 (P0.0/P0.1) | the XSENS | a :class:`~hil.flight.board_port.BoardPort` ("imu") |
| UART1 TXD1/RXD1 (P0.8/P0.9) | the vehicle's XBee | a BoardPort ("telemetry") |
| SPI0 SCK0/MISO0/MOSI0, /CS on GPIO P0.20 | the MCP3204 (the analog chain behind it); the adc port's bit-level wire faults act on MISO (tx) and MOSI (rx) | ``attach_spi_slave``, ``watch_gpio`` |
| CAP1.0 (P0.10) | the PPM receiver's pulse train | ``pin_edge`` at each edge's cycle |
| PWM2, PWM5, MAT1.2, MAT1.3 | ESC 0-3 | :class:`~hil.flight.board_esc.EscPins` |

Time: the board counts CCLK cycles and nanoseconds since its reset; sim time is board time
less ``offset_ns`` (boot runs at negative sim time; when it ends the offset moves so that the
first sample is one tick later, as on virtual time). :meth:`BoardWiring.run_to` runs the
firmware to a sim time in chunks: to each PPM edge (the bus only takes an input at the core's
current cycle) and at most ``CHUNK_NS`` apart; after each chunk the bytes the UARTs sent go to
the device models, whose replies go onto the line at the core's cycle then (a device answers
at most one chunk late). Everything is a function of cycles, never of the host's clock.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from emulators.lpc2148 import Lpc2148, SpiTransfer
from emulators.mcp3204.device import Mcp3204
from emulators.rc.ppm import PpmEdge
from hil.board.core import Core
from hil.board.elf import FirmwareImage
from hil.board.semihost import Semihost
from hil.flight.board_esc import EscPins
from hil.flight.board_port import BoardPort
from hil.flight.board_probes import FirmwareProbes
from hil.flight.devices import WireFilter
from hil.transport.base import Direction

PPM_PIN = (0, 10)  #: CAP1.0
ADC_CS_PIN = (0, 20)
#: longest stretch the core runs without the device models seeing the UARTs' bytes, ns
CHUNK_NS = 250_000


#: what the MCU reads on a dead SPI line (a cut MISO, like the MCP3204's DOUT in hi-Z) and what the
#: part reads on a cut MOSI: no start bit, so it never converts
DEAD_LINE = 0x00


def _through(filters: Sequence[WireFilter], direction: Direction, word: int, t_ns: int) -> int:
    """One SPI word through the adc port's wire faults (TX: MISO, RX: MOSI). Only faults that
    change bits act here (hil/faults/wire.py SPI_LINE_FAULTS): a word they take away is the
    dead line's."""
    data = bytes([word])
    for f in filters:
        data = f.tx(data, t_ns) if direction is Direction.TX else f.rx(data, t_ns)
    return data[0] if data else DEAD_LINE


@dataclass
class BoardRecords:
    """What crossed the pins that the ports do not record, since the run's logger last took it
    (sim ns)."""

    spi: list[tuple[int, int, int]] = field(default_factory=list)  #: (t_ns, mosi, miso) per SPI0 word
    cs: list[tuple[int, bool]] = field(default_factory=list)  #: (t_ns, level) of the ADC's /CS
    edges: list[tuple[int, bool]] = field(default_factory=list)  #: (t_ns, level) put on CAP1.0
    captures: list[tuple[int, int]] = field(default_factory=list)  #: (t_ns, CR0) Timer1 latched


class BoardWiring:
    """The board at its pins (see the module docstring). ``on_line(text)``: each line of the
    firmware's console (semihosting)."""

    def __init__(self, image: FirmwareImage, mcp: Mcp3204, on_line: Callable[[str], None],
                 wire_filters: Mapping[str, Sequence[WireFilter]] | None = None) -> None:
        self.image = image
        #: the run's wire faults by port (DeviceSet.wire_filters, changed in place as faults come
        #: and go): the adc's act on SPI0's lines
        self.wire_filters: Mapping[str, Sequence[WireFilter]] = {} if wire_filters is None else wire_filters
        self.bus = Lpc2148()
        self.core = Core(self.bus, Semihost(on_line=on_line))  # type: ignore[arg-type]  # scb: see mmio.SystemControlView
        self.core.load(image)
        self.core.reset(image.entry)
        self.probes = FirmwareProbes(self.core, image)
        self.mcp = mcp
        self.offset_ns = 0  #: board ns at sim time 0
        self.ports: dict[int, tuple[BoardPort, Callable[[], int]]] = {}
        self.escs = EscPins()
        self.records = BoardRecords()
        self._edges: deque[PpmEdge] = deque()
        self.bus.attach_spi_slave(self._spi)
        self.bus.watch_gpio(*ADC_CS_PIN, self._cs)

    # -- time --------------------------------------------------------------------------------------
    @property
    def cycles(self) -> int:
        return self.core.cycles

    def sim_ns(self, cycle: int) -> int:
        """Sim time of CCLK ``cycle``."""
        return self.bus.time.ns_at(cycle) - self.offset_ns

    def now_ns(self) -> int:
        return self.sim_ns(self.core.cycles)

    def cycle_at(self, t_ns: int) -> int:
        """The first cycle at or after sim ``t_ns`` (at the current clock)."""
        return self.bus.time.cycle_at_ns(t_ns + self.offset_ns)

    def rebase(self, now_ns: int, new_ns: int) -> None:
        """Sim time ``now_ns`` is called ``new_ns`` from here on (the end of boot)."""
        self.offset_ns += now_ns - new_ns
        self.escs.rebase(new_ns - now_ns)

    @property
    def stopped(self) -> bool:
        """The firmware ended (semihosting SYS_EXIT: its main returned)."""
        return self.core.semihost.exit_reason is not None

    # -- wiring ------------------------------------------------------------------------------------
    def port(self, name: str, uart: int, device_baud: Callable[[], int]) -> BoardPort:
        """A port whose client is UART ``uart``; its device sends at ``device_baud()`` bit/s."""
        port = BoardPort(name, uart, lambda data: self._line_in(uart, data))
        self.ports[uart] = (port, device_baud)
        return port

    def _line_in(self, uart: int, data: bytes) -> None:
        _, baud = self.ports[uart]
        self.bus.uart_line_in(uart, data, self.core.cycles, baud=baud())

    def feed_edges(self, edges: list[PpmEdge]) -> None:
        """PPM edges to put on CAP1.0 at their times (in order, not before the last one)."""
        self._edges.extend(edges)

    def _spi(self, mosi: int, transfer: SpiTransfer) -> int:
        t_ns = self.sim_ns(transfer.start)
        filters = self.wire_filters.get("adc")
        seen = _through(filters, Direction.RX, mosi, t_ns) if filters else mosi
        miso = self.mcp.exchange(bytes([seen]), t_ns, transfer.mode,
                                 f_sck_Hz=self.bus.cclk_hz / transfer.sck_period)[0]
        if filters:
            miso = _through(filters, Direction.TX, miso, t_ns)
        self.records.spi.append((t_ns, mosi, miso))  # at the MCU's pins: what it sent and read
        return miso

    def _cs(self, level: bool, cycle: int) -> None:
        t_ns = self.sim_ns(cycle)
        if level:
            self.mcp.deselect(t_ns)
        else:
            self.mcp.select(t_ns)
        self.records.cs.append((t_ns, level))

    # -- running -------------------------------------------------------------------------------------
    def run_to(self, t_ns: int) -> None:
        """Run the firmware to sim ``t_ns`` (see the module docstring); stops early if it ends
        or a debugger halts the core."""
        core, time, edges = self.core, self.bus.time, self._edges
        end = t_ns + self.offset_ns
        while not self.stopped and not core.halted:
            now = time.ns_at(core.cycles)
            if now >= end:
                break
            stop = min(end, now + CHUNK_NS)
            if edges:
                stop = min(stop, max(edges[0].t_ns + self.offset_ns, now))
            core.run_until(time.cycle_at_ns(stop))
            now = time.ns_at(core.cycles)
            while edges and edges[0].t_ns + self.offset_ns <= now:
                edge = edges.popleft()
                self.bus.pin_edge(*PPM_PIN, edge.level, core.cycles)
                self.records.edges.append((edge.t_ns, edge.level))
            self._collect()

    def _collect(self) -> None:
        """What the pins gave since the last chunk: UART bytes to the devices, ESC outputs,
        captures; the UARTs' programmed rates to the ports."""
        bus = self.bus
        for uart, (port, baud) in self.ports.items():
            model = bus.uart0 if uart == 0 else bus.uart1
            if model.fcr & 1:  # opened: the firmware enables the FIFOs after setting the rate
                port.programmed(bus.time.pclk_hz / model.bit_ticks, baud())
            sent = bus.take_uart_tx(uart)
            if sent:
                port.from_pins(bytes(b.value for b in sent), sent[-1].end_ns - self.offset_ns)
        for p in bus.take_pwm():
            self.escs.pwm(p.t_ns - self.offset_ns, p.channel, p.pulse_us, p.period_us)
        timer1 = bus.timer1
        outputs = timer1.take_match_outputs()
        if outputs:
            pinned = {c for c in (2, 3) if bus.pinsel.selected(f"MAT1.{c}")}
            for m in outputs:
                if m.channel in pinned:
                    self.escs.match(self.sim_ns(bus.cycle_of(timer1, m.tick)), m.channel, m.level)
        for c in timer1.take_captures():
            if c.channel == 0:
                self.records.captures.append((self.sim_ns(bus.cycle_of(timer1, c.tick)), c.value))
        bus.take_spi()  # recorded by the slave as it answers

    def take_records(self) -> BoardRecords:
        out, self.records = self.records, BoardRecords()
        return out
