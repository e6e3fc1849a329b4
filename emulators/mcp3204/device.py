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

Speed: ``exchange`` in mode 0,0 or 1,1 with CS low (what every driver does) takes whole
bytes at once from the tables of bytelevel.py; everything else (the wrong-phase modes, bytes
while CS is high or before the power-up CS high, raw pins) plays the edges one by one.
``Mcp3204(..., fast_path=False)`` plays edges for every byte: the reference the byte path is
tested against (tests/unit/adc/test_fastpath_equivalence.py).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from emulators.base import DeviceEvent
from emulators.mcp3204.bytelevel import (
    COMMAND_STEPS,
    OUTPUT_SEQUENCE_BITS,
    output_bits_cached,
    output_word,
)
from emulators.mcp3204.defs import (
    B0_INDEX,
    DIFF_PAIRS,
    N_CHANNELS,
    RISING_NEXT,
    Phase,
)
from emulators.mcp3204.params import Mcp3204Params
from emulators.mcp3204.transfer import quantize

#: sampler(channel 0..3, t_ns) -> volts at that input pin
Sampler = Callable[[int, int], float]

_OUTPUT = Phase.OUTPUT
_POWER_UP_CS_LOW = Phase.POWER_UP_CS_LOW
_WAIT_START = Phase.WAIT_START
#: Counter names per channel, single-ended and pseudo-differential (IN+).
_CODE_KEYS = {True: tuple(f"codes_ch{ch}" for ch in range(N_CHANNELS)),
              False: tuple(f"codes_diff_ch{ch}" for ch in range(N_CHANNELS))}


@dataclass(frozen=True, init=False)
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

    def __init__(self, t_ns: int, channel: int, single_ended: bool, code: int, volts: float, vref_V: float) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "channel", channel)
        object.__setattr__(self, "single_ended", single_ended)
        object.__setattr__(self, "code", code)
        object.__setattr__(self, "volts", volts)
        object.__setattr__(self, "vref_V", vref_V)


@dataclass(frozen=True)
class Mcp3204ProtocolError(DeviceEvent):
    """A bus misuse the part tolerates silently (the counters name it too)."""

    what: str


class Mcp3204:
    """One MCP3204. ``vref_V`` may be changed at run time (fault: reference drift)."""

    def __init__(self, params: Mcp3204Params, sampler: Sampler, *, fast_path: bool = True) -> None:
        self.params = params
        #: False: play every SCK edge of every byte (the reference for the byte-level path).
        self.fast_path = fast_path
        self.vref_V: float = params.vref_V
        #: A pull-up on the DOUT line outside the part (another device's on a shared MISO, a
        #: board's resistor): what a master reads while DOUT is hi-Z is 1 whatever it asks for.
        self.dout_pulled_up = False
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
        self._out: tuple[int, ...] = ()  # DOUT bits after the sample (defs.output_bits)
        self._word = 0  # the same bits packed (bytelevel.output_word)
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
        counters = self.counters
        n = len(mosi)
        if not 0 <= mode <= 3:
            counters["bad_spi_mode_arg"] += 1
            mode &= 3
        if mode == 1 or mode == 2:  # DS21298E §6.1 supports modes 0,0 and 1,1 only
            counters["wrong_phase_spi_bytes"] += n
        if f_sck_Hz is not None and f_sck_Hz > self.params.f_sck_max_Hz:
            counters["sck_over_spec_bytes"] += n
        if not self._cs_low:
            counters["bytes_while_deselected"] += n
        counters["spi_bytes"] += n
        if self.dout_pulled_up:
            hiz_bit = 1
        cpol = mode >> 1
        if self._sck != cpol:  # the master's clock returns to this mode's idle level
            self._edge(t_ns)
        if self.fast_path and (mode == 0 or mode == 3) and self._cs_low and self._phase is not _POWER_UP_CS_LOW:
            return self._exchange_bytes(mosi, t_ns, cpol, hiz_bit)
        return self._exchange_edges(mosi, t_ns, mode & 1, hiz_bit)

    def _exchange_edges(self, mosi: bytes, t_ns: int, cpha: int, hiz_bit: int) -> bytes:
        """The reference path: every SCK edge of every bit, in the order of SPI mode cpha."""
        out = bytearray()
        for byte in mosi:
            value = 0
            for i in range(7, -1, -1):
                bit = (byte >> i) & 1
                if cpha == 0:
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

    def _exchange_bytes(self, mosi: bytes, t_ns: int, cpol: int, hiz_bit: int) -> bytes:
        """Whole bytes in mode 0,0 (cpol 0) or 1,1 (cpol 1) with CS low: same bits, events,
        counters and sampler calls as :meth:`_exchange_edges`, a table lookup per byte."""
        steps = COMMAND_STEPS[cpol]
        hiz = 0xFF if hiz_bit else 0x00
        out = bytearray()
        for byte in mosi:
            phase = self._phase
            if phase is _OUTPUT:
                out.append(self._output_byte(byte, cpol, t_ns))
                continue
            new_phase, sgl, d_count, d_bits, sampled, k = steps[phase][byte]
            if sgl >= 0:
                self._sgl = sgl
            if d_count:
                self._d = ((self._d << d_count) | d_bits) & 0b111
            if sampled:  # the latches above all precede the sampling edge
                self._sample(t_ns)
                self._pos = pos = k - cpol
                self._dout = (self._word >> (OUTPUT_SEQUENCE_BITS - 1 - pos)) & 1
                out.append((hiz & (0xFF << k) & 0xFF) | (self._word >> (OUTPUT_SEQUENCE_BITS - k)))
            else:
                out.append(hiz)  # DOUT is hi-Z until the sample
            self._phase = new_phase
            self._din = byte & 1
            self._t_ns = t_ns
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

        Mode 0 samples before each falling edge (bits pos..pos+7 of the sequence), mode 3
        after it (pos+1..pos+8); DOUT advances one bit per clock either way. In edge order,
        the falling edge that reaches B0 (completing the conversion) comes before every
        rising edge that checks DIN past B0.
        """
        pos = self._pos
        first = pos + cpol
        word = self._word
        seq_bits = OUTPUT_SEQUENCE_BITS
        value = ((word << 8) >> (seq_bits - first)) & 0xFF if first <= seq_bits else 0  # zeros past the end
        end = pos + 8
        if pos < B0_INDEX <= end and self._conv is not None:
            self._complete(t_ns)
        if not self._frame_flagged and first + 7 >= B0_INDEX:
            for i in range(max(0, B0_INDEX - first), 8):  # the rising edges at or past B0
                self._din_after_b0(first + i, (byte >> (7 - i)) & 1, t_ns)
        self._pos = end
        self._dout = (word >> (OUTPUT_SEQUENCE_BITS - 1 - end)) & 1 if end < OUTPUT_SEQUENCE_BITS else 0
        self._din = byte & 1
        self._t_ns = t_ns
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
        phase = self._phase
        if self._conv is not None or not (phase is _OUTPUT or phase is _WAIT_START or phase is _POWER_UP_CS_LOW):
            self.counters["aborted_conversions"] += 1  # in RISING_NEXT, HOLD, or B0 not yet out
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
        self._out = output_bits_cached(code)
        self._word = output_word(code)
        self._conv = Mcp3204Conversion(t_ns, channel, single, code, vin, vref)

    def _complete(self, t_ns: int) -> None:
        conv = self._conv
        assert conv is not None
        self._conv = None
        self.counters["conversions"] += 1
        self.counters[_CODE_KEYS[conv.single_ended][conv.channel]] += 1
        self._events.append(conv)

    def _error(self, t_ns: int, what: str) -> None:
        self.counters["protocol_errors"] += 1
        self._events.append(Mcp3204ProtocolError(t_ns, what))
