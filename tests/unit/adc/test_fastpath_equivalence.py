"""The byte-level fast paths of the MCP3204 and the Bus Pirate against their reference paths.

``Mcp3204(..., fast_path=False)`` plays every SCK edge of every byte (the clock-level model
of DS21298E §5.0/§6.0); ``BusPirate(..., fast_path=False)`` handles every received byte on
its own, as the firmware's UART loop does. The fast paths must be indistinguishable from
them: the same MISO bytes, events (same order, same fields), counters (same keys in the same
order), pin levels and sampler calls (same channels, times and order, so a seeded analog
front-end draws the same noise) for random framings (CS toggles, byte splits, SPI modes 0 to
3, leading zeros, single-ended and differential requests, garbage, raw pin writes) and
random voltages.

Golden bytes: DS21298E Fig. 6-1 (request ``06 40 00`` reads CH1, reply ``?? 0B BB``
with the code in the low 12 bits); the Bus Pirate's pipelined transaction ``02 1n <data>
03`` answers ``01 01 <miso> 01`` (DP wiki "SPI (binary)", docs/protocols.md §7.1).
"""

from __future__ import annotations

import math

import hypothesis.strategies as st
import numpy as np
from hypothesis import given, settings

from emulators.analog.frontend import AnalogFrontEnd
from emulators.analog.params import AnalogParams
from emulators.buspirate import BusPirate, BusPirateParams
from emulators.mcp3204 import (
    Mcp3204,
    Mcp3204Params,
    fig61_decode,
    fig61_request,
    quantize,
)
from emulators.mcp3204.bytelevel import (
    COMMAND_PHASES,
    COMMAND_STEPS,
    command_step,
    output_word,
)
from emulators.mcp3204.defs import Phase, output_bits

# -- helpers ----------------------------------------------------------------------------------


class NoisySampler:
    """Input voltages plus white noise from its own seeded Generator; logs every call."""

    def __init__(self, volts: list[float], noise_V: float, seed: int) -> None:
        self.volts = list(volts)
        self.noise_V = noise_V
        self.rng = np.random.default_rng(seed)
        self.calls: list[tuple[int, int]] = []

    def __call__(self, channel: int, t_ns: int) -> float:
        self.calls.append((channel, t_ns))
        return self.volts[channel] + self.noise_V * float(self.rng.standard_normal())


def mcp_pair(volts: list[float], noise_V: float, **params: object) -> tuple[Mcp3204, Mcp3204]:
    """(fast, reference) parts with identical, identically seeded samplers."""
    p = Mcp3204Params(**params)  # type: ignore[arg-type]
    return (Mcp3204(p, NoisySampler(volts, noise_V, 7), fast_path=True),
            Mcp3204(p, NoisySampler(volts, noise_V, 7), fast_path=False))


def mcp_state(adc: Mcp3204) -> tuple[object, ...]:
    """Everything observable: pins, phase, counters in insertion order, sampler log."""
    sampler = adc._sampler
    assert isinstance(sampler, NoisySampler)
    return (adc.cs_low, adc.phase, adc.sck, adc.din, adc.dout, list(adc.counters.items()), sampler.calls,
            adc.vref_V)


def frame_bytes(lead: int, sgl: int, d: int, tail: list[int]) -> bytes:
    """``lead`` zero bits, the start bit, SGL/DIFF, D2 D1 D0, then ``tail`` bits, padded to
    whole bytes with zeros."""
    bits = [0] * lead + [1, sgl, (d >> 2) & 1, (d >> 1) & 1, d & 1] + tail
    bits += [0] * (-len(bits) % 8)
    return bytes(int("".join(map(str, bits[i : i + 8])), 2) for i in range(0, len(bits), 8))


def split(data: bytes, cuts: list[int]) -> list[bytes]:
    """``data`` cut after the given piece lengths (the rest in a last piece)."""
    pieces, pos = [], 0
    for n in cuts:
        if pos >= len(data):
            break
        pieces.append(data[pos : pos + n])
        pos += n
    if pos < len(data):
        pieces.append(data[pos:])
    return pieces


@st.composite
def requests(draw: st.DrawFn) -> bytes:
    """An MCP3204 request as drivers send it (any number of leading zeros, single-ended or
    differential, any tail), or garbage."""
    if draw(st.integers(0, 4)) == 0:
        return draw(st.binary(min_size=1, max_size=6))
    lead = draw(st.integers(0, 14))
    tail = draw(st.lists(st.integers(0, 1), min_size=0, max_size=30))
    return frame_bytes(lead, draw(st.integers(0, 1)), draw(st.integers(0, 7)), tail)


VOLTAGE = st.one_of(st.floats(-0.5, 5.5), st.sampled_from([0.0, 5.0, math.nan, math.inf, -math.inf, 2.5]))


@st.composite
def mcp_ops(draw: st.DrawFn) -> list[tuple]:
    """A bus session: frames in random modes and splits, CS toggles, stray clocks, raw pin
    writes, VREF and input changes."""
    ops: list[tuple] = []
    for _ in range(draw(st.integers(1, 8))):
        kind = draw(st.integers(0, 9))
        if kind <= 5:  # a framed request, split across exchanges; CS raised or not after it
            mode = draw(st.sampled_from([0, 3, 0, 3, 1, 2]))
            ops.append(("sck", mode >> 1))
            if draw(st.booleans()) or kind == 0:
                ops.append(("select",))
            data = draw(requests())
            hiz = draw(st.integers(0, 1))
            f_sck = draw(st.sampled_from([None, 1e6, 3e6]))
            for piece in split(data, draw(st.lists(st.integers(1, 4), max_size=4))):
                ops.append(("xfer", piece, mode, hiz, f_sck))
            if draw(st.integers(0, 3)):
                ops.append(("deselect",))
        elif kind == 6:
            ops.append(("xfer", draw(st.binary(min_size=0, max_size=4)), draw(st.integers(-1, 4)),
                        draw(st.integers(0, 1)), None))
        elif kind == 7:
            ops.append(("pins", draw(st.integers(0, 1)), draw(st.integers(0, 1)), draw(st.integers(0, 1))))
        elif kind == 8:
            ops.append(("vref", draw(st.sampled_from([5.0, 4.096, 0.1, 0.0, -1.0, 6.0]))))
        else:
            ops.append(("volts", draw(st.integers(0, 3)), draw(VOLTAGE)))
    return ops


def run_mcp(adc: Mcp3204, op: tuple, t_ns: int) -> tuple[object, ...]:
    """Apply ``op``; return what it gave back and the events it produced."""
    kind = op[0]
    out: object = None
    if kind == "select":
        adc.select(t_ns)
    elif kind == "deselect":
        adc.deselect(t_ns)
    elif kind == "sck":
        adc.set_sck(op[1], t_ns)
    elif kind == "xfer":
        out = adc.exchange(op[1], t_ns, op[2], hiz_bit=op[3], f_sck_Hz=op[4])
    elif kind == "pins":
        out = adc.set_pins(t_ns, op[1], op[2], op[3])
    elif kind == "vref":
        adc.vref_V = op[1]
    else:
        sampler = adc._sampler
        assert isinstance(sampler, NoisySampler)
        sampler.volts[op[1]] = op[2]
    return out, repr(adc.take_events())  # repr: NaN volts compare equal as text


# -- the tables themselves ----------------------------------------------------------------------


def test_tables_cover_every_command_phase_byte_and_mode() -> None:
    for cpol in (0, 1):
        assert set(COMMAND_STEPS[cpol]) == set(COMMAND_PHASES)
        for phase in COMMAND_PHASES:
            row = COMMAND_STEPS[cpol][phase]
            assert len(row) == 256 and row[0x5A] == command_step(phase, 0x5A, cpol)


def test_golden_fig_6_1_steps() -> None:
    # DS21298E Fig. 6-1, mode 0,0: 06 = 0000 0110 carries the start bit, SGL = 1 and D2 = 0;
    # 40 = 01xx xxxx carries D1 D0 = 01; the null bit and B11..B8 fill the low 5 bits.
    first = COMMAND_STEPS[0][Phase.WAIT_START][0x06]
    assert (first.phase, first.sgl, first.d_count, first.d_bits, first.sampled) == (Phase.D1, 1, 1, 0, False)
    second = COMMAND_STEPS[0][Phase.D1][0x40]
    assert (second.phase, second.d_count, second.d_bits, second.sampled, second.out_bits) == (
        Phase.OUTPUT, 2, 0b01, True, 5)
    # Mode 1,1 samples one edge later in time but reads the same bits.
    assert COMMAND_STEPS[1][Phase.D1][0x40].out_bits == 5


@given(st.integers(0, 4095))
@settings(deadline=None, max_examples=200)
def test_output_word_is_the_datasheet_bit_sequence(code: int) -> None:
    word = output_word(code)
    assert tuple((word >> (23 - i)) & 1 for i in range(24)) == output_bits(code)


# -- MCP3204: fast path == clock-level reference ----------------------------------------------------


def test_fig_6_1_exchange_gives_the_reference_bytes_and_code() -> None:
    fast, ref = mcp_pair([1.0, 2.0, 3.0, 4.0], 0.0)
    for ch in range(4):
        for adc in (fast, ref):
            adc.select(0)
        rx = fast.exchange(fig61_request(ch), 0, 0)
        assert rx == ref.exchange(fig61_request(ch), 0, 0)
        assert fig61_decode(rx) == quantize(float(ch + 1), 5.0)
        for adc in (fast, ref):
            adc.deselect(0)
    assert mcp_state(fast) == mcp_state(ref)
    assert repr(fast.take_events()) == repr(ref.take_events())


def test_conversion_completes_before_the_b0_din_check_as_on_the_pins() -> None:
    """A host that starts a new command right after B0 without raising CS: the conversion
    (at the falling edge that shifts B0 out) is recorded before the protocol error (at a
    later rising edge), the order in which the pin-level model sees them."""
    mosi = bytes([0x00, 0xC0, 0x00, 0x10, 0x00])  # start bit at bit 8: a 0 then a 1 after B0
    pins = Mcp3204(Mcp3204Params(), lambda ch, t: 1.234)
    pins.set_pins(0, 1, 0, 0)
    pins.set_pins(0, 0, 0, 0)
    expect = bytearray()
    for byte in mosi:
        value = 0
        for i in range(7, -1, -1):
            bit = (byte >> i) & 1
            dout = pins.set_pins(5, 0, 0, bit)
            value = value << 1 | (dout or 0)
            pins.set_pins(5, 0, 1, bit)
            pins.set_pins(5, 0, 0, bit)
        expect.append(value)
    for fast_path in (True, False):
        adc = Mcp3204(Mcp3204Params(), lambda ch, t: 1.234, fast_path=fast_path)
        adc.select(0)
        assert adc.exchange(mosi, 5, 0) == bytes(expect)
        assert [type(e).__name__ for e in adc.take_events()] == ["Mcp3204Conversion", "Mcp3204ProtocolError"]
    assert [type(e).__name__ for e in pins.take_events()] == ["Mcp3204Conversion", "Mcp3204ProtocolError"]


@settings(deadline=None, max_examples=300)
@given(mcp_ops(), st.lists(VOLTAGE, min_size=4, max_size=4), st.sampled_from([0.0, 1e-3]),
       st.booleans(), st.sampled_from([(0.0, 0.0), (1.1, -0.7)]))
def test_mcp3204_fast_path_matches_the_edge_by_edge_reference(
    ops: list[tuple], volts: list[float], noise_V: float, cs_low_at_power_up: bool, errors_lsb: tuple[float, float]
) -> None:
    fast, ref = mcp_pair(volts, noise_V, cs_low_at_power_up=cs_low_at_power_up,
                         offset_error_lsb=errors_lsb[0], gain_error_lsb=errors_lsb[1])
    for k, op in enumerate(ops):
        t_ns = 1000 * k
        assert run_mcp(fast, op, t_ns) == run_mcp(ref, op, t_ns), op
        assert mcp_state(fast) == mcp_state(ref), op


@settings(deadline=None, max_examples=100)
@given(st.lists(requests(), min_size=1, max_size=6), st.sampled_from([0, 3]), st.integers(0, 1),
       st.lists(st.integers(1, 7), max_size=12), st.lists(VOLTAGE, min_size=4, max_size=4))
def test_one_exchange_equals_the_same_bytes_one_at_a_time(
    frames: list[bytes], mode: int, hiz: int, cuts: list[int], volts: list[float]
) -> None:
    """CS held low over a burst of requests (the part ignores new start bits until CS rises):
    whole, in pieces and byte by byte give the same bits, events and counts."""
    stream = b"".join(frames)
    whole, ref = mcp_pair(volts, 1e-3)
    pieces, _ = mcp_pair(volts, 1e-3)
    for adc in (whole, pieces, ref):
        adc.set_sck(mode >> 1, 0)
        adc.select(0)
    rx_whole = whole.exchange(stream, 10, mode, hiz_bit=hiz)
    rx_pieces = b"".join(pieces.exchange(p, 10, mode, hiz_bit=hiz) for p in split(stream, cuts))
    rx_ref = b"".join(ref.exchange(stream[i : i + 1], 10, mode, hiz_bit=hiz) for i in range(len(stream)))
    assert rx_whole == rx_pieces == rx_ref
    assert repr(whole.take_events()) == repr(pieces.take_events()) == repr(ref.take_events())
    assert mcp_state(whole) == mcp_state(pieces) == mcp_state(ref)


# -- Bus Pirate + MCP3204: batched receive == one byte at a time through the reference part -----


def analog_sampler(seed: int) -> AnalogFrontEnd:
    """The bench's real sampler: seeded sensor and electrical noise drawn per sample."""
    return AnalogFrontEnd(AnalogParams(), np.random.default_rng(seed))


def bp_pair(seed: int, **params: object) -> tuple[BusPirate, BusPirate, AnalogFrontEnd, AnalogFrontEnd]:
    a_fast, a_ref = analog_sampler(seed), analog_sampler(seed)
    p = BusPirateParams(**params)  # type: ignore[arg-type]
    fast = BusPirate(p, Mcp3204(Mcp3204Params(), a_fast.volts))
    ref = BusPirate(p, Mcp3204(Mcp3204Params(), a_ref.volts, fast_path=False), fast_path=False)
    return fast, ref, a_fast, a_ref


ENTRY = bytes(20) + b"\x01"


def by_device(events: list) -> tuple[str, str]:
    """(the MCP3204's events, the Bus Pirate's events), each in order, as text."""
    part = [e for e in events if type(e).__name__.startswith("Mcp3204")]
    return repr(part), repr([e for e in events if not type(e).__name__.startswith("Mcp3204")])


@st.composite
def spi_commands(draw: st.DrawFn) -> bytes:
    """One SPI-mode command as a host may send it."""
    kind = draw(st.integers(0, 12))
    if kind <= 4:  # the flight code's transaction, any request inside, any length
        data = draw(requests())[:16]
        return bytes((0x02, 0x10 | (len(data) - 1))) + data + b"\x03"
    if kind == 5:
        return bytes((0x80 | draw(st.integers(0, 15)),))  # config: HiZ/3.3 V, CKP, CKE, SMP
    if kind == 6:
        return bytes((0x40 | draw(st.integers(0, 15)),))  # peripherals: power, pull-ups, AUX, CS
    if kind == 7:
        return bytes((0x60 | draw(st.integers(0, 7)),))  # speed
    if kind == 8:
        return draw(st.sampled_from([b"\x02", b"\x03"]))
    if kind == 9:  # write-then-read with or without CS
        data = draw(requests())
        n_read = draw(st.integers(0, 4))
        cmd = draw(st.sampled_from([0x04, 0x05]))
        return bytes((cmd, 0, len(data), 0, n_read)) + data
    if kind == 10:  # a bulk transfer without CS handling around it
        data = draw(st.binary(min_size=1, max_size=16))
        return bytes((0x10 | (len(data) - 1),)) + data
    if kind == 11:
        return draw(st.sampled_from([b"\x00\x01", b"\x01", b"\x50\x70\x90", b"\x0d\x00", b"\x0f" + ENTRY]))
    return draw(st.binary(min_size=1, max_size=3))  # garbage


@settings(deadline=None, max_examples=300)
@given(st.lists(spi_commands(), min_size=1, max_size=12), st.lists(st.integers(1, 12), max_size=20),
       st.integers(0, 2**16), st.booleans())
def test_bus_pirate_batched_receive_matches_byte_at_a_time_reference(
    commands: list[bytes], cuts: list[int], seed: int, target_pullups: bool
) -> None:
    fast, ref, a_fast, a_ref = bp_pair(seed, target_pullups=target_pullups)
    for bp in (fast, ref):
        bp.line_settings_changed(115_200, 0)
        bp.receive(ENTRY + b"\x8a\x63\x49\x03", 0)  # the flight code's entry and setup
    assert fast.take_output() == ref.take_output()
    stream = b"".join(commands)
    for k, piece in enumerate(split(stream, cuts)):
        t_ns = 2_500_000 * (k + 1)
        for a in (a_fast, a_ref):  # the latch moves between writes, as on the bench
            a.update(t_ns, 101_325.0 - 12.0 * k, (0.1 * k, -0.2, -9.8), 25.0)
        fast.receive(piece, t_ns)
        for i in range(len(piece)):
            ref.receive(piece[i : i + 1], t_ns)
        assert fast.take_output() == ref.take_output()
        # The part's events join the bridge's at the end of each receive call, so only
        # each device's own sequence is independent of the fragmentation.
        assert by_device(fast.take_events()) == by_device(ref.take_events())
        assert dict(fast.counters) == dict(ref.counters)
        assert list(fast.adc.counters.items()) == list(ref.adc.counters.items())
        assert (fast.mode, fast.adc.phase, fast.adc.cs_low, fast.adc.sck) == (
            ref.mode, ref.adc.phase, ref.adc.cs_low, ref.adc.sck)
    assert a_fast.counters == a_ref.counters
    assert a_fast.volts(0, 10**12) == a_ref.volts(0, 10**12)  # the noise streams stayed in step


@settings(deadline=None, max_examples=60)
@given(st.lists(spi_commands(), min_size=1, max_size=10), st.lists(st.integers(1, 9), max_size=15),
       st.integers(0, 2**16))
def test_bus_pirate_fast_and_reference_agree_on_the_same_fragments(
    commands: list[bytes], cuts: list[int], seed: int
) -> None:
    """Same fragments into both: identical down to the order of the counters' keys."""
    fast, ref, _, _ = bp_pair(seed)
    for bp in (fast, ref):
        bp.receive(ENTRY + b"\x8a", 0)
    for k, piece in enumerate(split(b"".join(commands), cuts)):
        for bp in (fast, ref):
            bp.receive(piece, 1000 * k)
        assert fast.take_output() == ref.take_output()
        assert repr(fast.take_events()) == repr(ref.take_events())
        assert list(fast.counters.items()) == list(ref.counters.items())


def test_flight_code_pipelined_read_of_four_channels() -> None:
    """``02 12 <06 c0 00> 03`` per channel in one write (flightcode/drivers/buspirate_spi.py)
    answers ``01 01 <3 bytes> 01`` per channel, the codes of the latched voltages."""
    fast, ref, a_fast, a_ref = bp_pair(3)
    wire = b"".join(b"\x02\x12" + fig61_request(ch) + b"\x03" for ch in range(4))
    for bp in (fast, ref):
        bp.receive(ENTRY + b"\x8a\x63\x49\x03", 0)
        bp.take_output()
        bp.take_events()
    for a in (a_fast, a_ref):
        a.update(2_500_000, 101_325.0, (0.0, 0.0, -9.80665), 25.0)
    fast.receive(wire, 2_500_000)
    ref.receive(wire, 2_500_000)
    rx = fast.take_output()
    assert rx == ref.take_output() and len(rx) == 24
    events = fast.take_events()
    assert repr(events) == repr(ref.take_events())
    codes = [e.code for e in events if type(e).__name__ == "Mcp3204Conversion"]
    assert [fig61_decode(rx[6 * ch + 2 : 6 * ch + 5]) for ch in range(4)] == codes
    assert [rx[6 * ch : 6 * ch + 2] + rx[6 * ch + 5 : 6 * ch + 6] for ch in range(4)] == [b"\x01\x01\x01"] * 4
    assert [e.channel for e in events if type(e).__name__ == "Mcp3204Conversion"] == [0, 1, 2, 3]
