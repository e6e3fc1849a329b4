"""The MCP3204 as an SPI slave, modelled edge by edge.

Two ways in, sharing one pin-level model:

* ``select(t_ns)`` / ``deselect(t_ns)`` / ``exchange(mosi, t_ns, mode)``: what an SPI master
  (the Bus Pirate or SPIDriver bridge) does. ``exchange`` plays the SCK edges of the given
  SPI mode against the part, one MISO byte per MOSI byte (full duplex, MSB first).
* ``set_pins(t_ns, cs, sck, din)``: raw pin levels, for a host that bit-bangs the bus.

Timing rules at an edge: the side that samples sees the level from before the edge (hold
time), then the side that drives changes. The part latches DIN on rising edges and changes
DOUT on falling edges, so modes 0,0 and 1,1 work and the two wrong-phase modes return data
shifted by one bit, as a real part does.

The analog input is sampled at the end of the sample phase by calling
``sampler(channel, t_ns)`` (volts at that input pin) with the ``t_ns`` of the transaction.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from emulators.base import DeviceEvent
from emulators.mcp3204.defs import (
    B0_INDEX,
    DIFF_PAIRS,
    RISING_NEXT,
    SUPPORTED_SPI_MODES,
    Phase,
    SpiMode,
    output_bits,
)
from emulators.mcp3204.params import Mcp3204Params
from emulators.mcp3204.transfer import quantize

#: sampler(channel 0..3, t_ns) -> volts at that input pin
Sampler = Callable[[int, int], float]


@dataclass(frozen=True)
class Mcp3204Conversion(DeviceEvent):
    """One completed conversion (B0 shifted out).

    ``channel`` is the single-ended input or IN+ of the pair; ``volts`` is VIN (IN+ - IN-
    in pseudo-differential mode) at the sample instant; ``code`` 0..4095.
    """

    channel: int
    single_ended: bool
    code: int
    volts: float
    vref_V: float


@dataclass(frozen=True)
class Mcp3204ProtocolError(DeviceEvent):
    """A bus misuse the part tolerates silently (the counters name it too)."""

    what: str


class Mcp3204:
    """One MCP3204. ``vref_V`` may be changed at run time (fault: reference drift)."""

    def __init__(self, params: Mcp3204Params, sampler: Sampler) -> None:
        self.params = params
        self.vref_V: float = params.vref_V
        self.counters: Counter[str] = Counter()
        self._sampler = sampler
        self._events: list[DeviceEvent] = []
        self._cs_low = params.cs_low_at_power_up
        self._phase = Phase.POWER_UP_CS_LOW if self._cs_low else Phase.IDLE
        self._sck = 0
        self._din = 0
        self._dout: int | None = None  # None = hi-Z
        self._t_ns = 0
        self._sgl = 1
        self._d = 0  # D2 D1 D0 as latched
        self._out: tuple[int, ...] = ()
        self._pos = 0
        self._conv: Mcp3204Conversion | None = None
        self._frame_flagged = False
        self._zero_after_b0 = False

    # -- observers ---------------------------------------------------------------------
    @property
    def cs_low(self) -> bool:
        return self._cs_low

    @property
    def phase(self) -> Phase:
        return self._phase

    @property
    def sck(self) -> int:
        """SCK level the part last saw."""
        return self._sck

    @property
    def din(self) -> int:
        """DIN level the part last saw."""
        return self._din

    @property
    def dout(self) -> int | None:
        """DOUT level, None while hi-Z."""
        return self._dout

    def take_events(self) -> list[DeviceEvent]:
        """Drain conversion and protocol-error events."""
        events, self._events = self._events, []
        return events

    # -- SPI master view ---------------------------------------------------------------
    def select(self, t_ns: int) -> None:
        """CS high -> low (the falling edge starts a frame)."""
        self._set_cs(0, t_ns)

    def deselect(self, t_ns: int) -> None:
        """CS low -> high (ends the frame, DOUT hi-Z, part shuts down)."""
        self._set_cs(1, t_ns)

    def exchange(
        self, mosi: bytes, t_ns: int, mode: int = 0, *, hiz_bit: int = 0, f_sck_Hz: float | None = None
    ) -> bytes:
        """Clock ``mosi`` out MSB first in SPI ``mode`` (0..3); return the MISO bytes.

        ``hiz_bit`` is what the master reads while DOUT is hi-Z (0 for a floating line,
        1 with a pull-up). ``f_sck_Hz`` (optional) is only checked against the part's
        limit and counted.
        """
        if not 0 <= mode <= 3:
            self.counters["bad_spi_mode_arg"] += 1
            mode &= 3
        if SpiMode(mode) not in SUPPORTED_SPI_MODES:
            self.counters["wrong_phase_spi_bytes"] += len(mosi)
        if f_sck_Hz is not None and f_sck_Hz > self.params.f_sck_max_Hz:
            self.counters["sck_over_spec_bytes"] += len(mosi)
        if not self._cs_low:
            self.counters["bytes_while_deselected"] += len(mosi)
        self.counters["spi_bytes"] += len(mosi)
        cpol, cpha = mode >> 1, mode & 1
        if self._sck != cpol:  # the master's clock returns to this mode's idle level
            self._edge(t_ns)
        out = bytearray()
        for byte in mosi:
            if self._phase is Phase.OUTPUT and cpha == cpol and self._cs_low:
                out.append(self._output_byte(byte, cpol, t_ns))
                continue
            value = 0
            matched = cpha == cpol and self._cs_low and self._phase is not Phase.POWER_UP_CS_LOW
            for i in range(7, -1, -1):
                bit = (byte >> i) & 1
                if matched:  # a whole clock of mode 0,0 or 1,1 without the edge dispatch
                    self._t_ns = t_ns
                    if cpol:
                        self._falling(t_ns)
                    self._din = bit
                    sample = hiz_bit if self._dout is None else self._dout
                    self._rising(t_ns)
                    if not cpol:
                        self._falling(t_ns)
                elif cpha == 0:
                    self._din = bit  # data set up before the leading edge
                    sample = self._miso(hiz_bit)  # master samples on the leading edge
                    self._edge(t_ns)
                    self._edge(t_ns)
                else:
                    self._edge(t_ns)  # leading edge: the part still sees the old DIN
                    self._din = bit
                    sample = self._miso(hiz_bit)  # trailing edge: sampled before it acts
                    self._edge(t_ns)
                value = (value << 1) | sample
            out.append(value)
        return bytes(out)

    def set_sck(self, level: int, t_ns: int) -> None:
        """Drive SCK to ``level``: masters call this when their clock idle level (CPOL)
        changes, before lowering CS, so the part sees no stray edge in the frame."""
        if (level & 1) != self._sck:
            self._edge(t_ns)

    # -- pin view ----------------------------------------------------------------------
    def set_pins(self, t_ns: int, cs: int, sck: int, din: int) -> int | None:
        """Drive CS, SCK and DIN to these levels; return DOUT (None = hi-Z).

        Applied in the order DIN, SCK, CS (the order the Bus Pirate's pin writes settle).
        """
        self._din = din & 1
        if (sck & 1) != self._sck:
            self._edge(t_ns)
        self._set_cs(cs & 1, t_ns)
        return self._dout

    # -- internals ---------------------------------------------------------------------
    def _output_byte(self, byte: int, cpol: int, t_ns: int) -> int:
        """Eight clocks of the OUTPUT phase in mode 0,0 or 1,1, without simulating edges.

        Same result as the edge path: mode 0 samples before each falling edge (out[pos]),
        mode 3 after it (out[pos + 1]); DOUT advances one bit per clock either way.
        """
        out, pos = self._out, self._pos
        first = pos + cpol
        bits = out[first : first + 8]
        value = 0
        for bit in bits:
            value = (value << 1) | bit
        value <<= 8 - len(bits)  # past the LSB-first copy: zeros
        if not self._frame_flagged and pos + cpol + 7 >= B0_INDEX:
            for i in range(8):  # the edge path's check at each rising edge (pos at that edge)
                self._din_after_b0(pos + cpol + i, (byte >> (7 - i)) & 1, t_ns)
        self._pos = pos + 8
        self._dout = out[self._pos] if self._pos < len(out) else 0
        self._din = byte & 1
        self._t_ns = t_ns
        if pos < B0_INDEX <= self._pos and self._conv is not None:
            self._complete(t_ns)
        return value

    def _din_after_b0(self, pos: int, din: int, t_ns: int) -> None:
        """DIN is don't care once B0 is out, but a 0 followed by a 1 there is a host
        starting its next command without raising CS (dummy bytes are all 0 or all 1)."""
        if pos < B0_INDEX or self._frame_flagged:
            return
        if not din:
            self._zero_after_b0 = True
        elif self._zero_after_b0:
            self._frame_flagged = True
            self.counters["cs_not_raised_between_conversions"] += 1
            self._error(t_ns, "start of a new command while CS stayed low; the part ignores it")

    def _miso(self, hiz_bit: int) -> int:
        return hiz_bit if self._dout is None else self._dout

    def _set_cs(self, level: int, t_ns: int) -> None:
        if level == 0:
            if self._cs_low:
                return
            self._cs_low = True
            self._phase = Phase.WAIT_START
            self._dout = None
            self._conv = None
            self._frame_flagged = False
            self._zero_after_b0 = False
            self.counters["transactions"] += 1
            return
        if not self._cs_low:
            return
        if self._phase in RISING_NEXT or self._phase is Phase.HOLD or self._conv is not None:
            self.counters["aborted_conversions"] += 1
        self._cs_low = False
        self._phase = Phase.IDLE
        self._dout = None
        self._conv = None

    def _edge(self, t_ns: int) -> None:
        self._sck ^= 1
        self._t_ns = t_ns
        if not self._cs_low:
            return
        if self._phase is Phase.POWER_UP_CS_LOW:
            self.counters["clocks_before_cs_raised"] += self._sck  # count rising edges
            if not self._frame_flagged:
                self._frame_flagged = True
                self._error(t_ns, "clocked after power-up with CS low; CS must go high first")
            return
        if self._sck:
            self._rising(t_ns)
        else:
            self._falling(t_ns)

    def _rising(self, t_ns: int) -> None:
        phase = self._phase
        if phase is Phase.WAIT_START:
            if self._din:
                self._phase = Phase.SGL_DIFF
            return
        if phase is Phase.SGL_DIFF:
            self._sgl = self._din
        elif phase in (Phase.D2, Phase.D1, Phase.D0):
            self._d = ((self._d << 1) | self._din) & 0b111
        elif phase is Phase.OUTPUT:
            if not self._frame_flagged:
                self._din_after_b0(self._pos, self._din, t_ns)
            return
        self._phase = RISING_NEXT.get(phase, phase)

    def _falling(self, t_ns: int) -> None:
        if self._phase is Phase.HOLD:
            self._sample(t_ns)
            self._phase = Phase.OUTPUT
            self._pos = 0
            self._dout = self._out[0]
            return
        if self._phase is not Phase.OUTPUT:
            return
        self._pos += 1
        self._dout = self._out[self._pos] if self._pos < len(self._out) else 0
        if self._pos == B0_INDEX and self._conv is not None:
            self._complete(t_ns)

    def _sample(self, t_ns: int) -> None:
        single = bool(self._sgl)
        d10 = self._d & 0b11  # D2 is don't care on the MCP3204
        if single:
            channel = d10
            vin = float(self._sampler(d10, t_ns))
        else:
            plus, minus = DIFF_PAIRS[d10]
            channel = plus
            vin = float(self._sampler(plus, t_ns)) - float(self._sampler(minus, t_ns))
        vref = self.vref_V
        if not 0.25 <= vref <= self.params.vdd_V:
            self.counters["vref_out_of_spec"] += 1
        code = quantize(vin, vref, self.params.offset_error_lsb, self.params.gain_error_lsb)
        self._out = output_bits(code)
        self._conv = Mcp3204Conversion(t_ns, channel, single, code, vin, vref)

    def _complete(self, t_ns: int) -> None:
        conv = self._conv
        assert conv is not None
        self._conv = None
        self.counters["conversions"] += 1
        key = f"codes_ch{conv.channel}" if conv.single_ended else f"codes_diff_ch{conv.channel}"
        self.counters[key] += 1
        self._events.append(conv)

    def _error(self, t_ns: int, what: str) -> None:
        self.counters["protocol_errors"] += 1
        self._events.append(Mcp3204ProtocolError(t_ns, what))
