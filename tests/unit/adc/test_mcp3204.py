"""MCP3204 clock-level model: golden exchanges, every driver framing, bad bus use.

Golden sources: Microchip DS21298E Fig. 6-1 (3-byte mode 0,0 exchange: MOSI 0000 01 S D2,
D1 D0 xxxxxx, xxxxxxxx; MISO ??? 0 B11..B8, B7..B0), Table 5-1 (channel codes), §5.0 (LSB
first after B0, then zeros); docs/protocols.md §2-3 (h = 0 m -> 101.325 kPa -> 4.085 V
-> code 3346 at VREF 5 V).
"""

from __future__ import annotations

import hypothesis.strategies as st
from hypothesis import given, settings
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from emulators.mcp3204 import (
    Mcp3204,
    Mcp3204Conversion,
    Mcp3204Params,
    Mcp3204ProtocolError,
    code_center_V,
    fig61_decode,
    fig61_request,
    lsb_V,
    quantize,
)

# ISA sea level through the MPX5100AP at Vs = 5 V: 5 * (0.009 * 101.325 - 0.095) V.
V_SEA_LEVEL = 5.0 * (0.009 * 101.325 - 0.095)
VOLTS = [V_SEA_LEVEL, 1.0, 2.5, 4.999]
CODES = [3346, 819, 2048, 4095]


class Pins:
    """Settable input voltages; records every sampler call."""

    def __init__(self, volts: list[float]) -> None:
        self.volts = list(volts)
        self.calls: list[tuple[int, int]] = []

    def __call__(self, channel: int, t_ns: int) -> float:
        self.calls.append((channel, t_ns))
        return self.volts[channel]


def make(volts: list[float] | None = None, **kw: object) -> tuple[Mcp3204, Pins]:
    pins = Pins(VOLTS if volts is None else volts)
    return Mcp3204(Mcp3204Params(**kw), pins), pins  # type: ignore[arg-type]


def read(adc: Mcp3204, request: bytes, t_ns: int = 0, mode: int = 0, hiz_bit: int = 0) -> bytes:
    adc.select(t_ns)
    rx = adc.exchange(request, t_ns, mode, hiz_bit=hiz_bit)
    adc.deselect(t_ns)
    return rx


def test_golden_requests_are_the_datasheet_bytes() -> None:
    assert [fig61_request(ch).hex(" ") for ch in range(4)] == ["06 00 00", "06 40 00", "06 80 00", "06 c0 00"]
    assert fig61_request(1, single_ended=False).hex(" ") == "04 40 00"


def test_golden_three_byte_reads_give_exact_codes_and_bytes() -> None:
    adc, _ = make()
    for ch, code in enumerate(CODES):
        rx = read(adc, fig61_request(ch))
        assert fig61_decode(rx) == code
        # hi-Z bits read as the floating level (0 here), then the null bit, then B11..B8.
        assert rx == bytes([0x00, code >> 8, code & 0xFF])
    # With a pull-up on MISO the hi-Z bits read 1: 1110 1101 for code 0xD12.
    rx = read(adc, fig61_request(0), hiz_bit=1)
    assert rx.hex() == "ffed12"


def test_sea_level_table_value() -> None:
    assert quantize(V_SEA_LEVEL, 5.0) == 3346
    assert abs(V_SEA_LEVEL - 4.085) < 0.001


def test_fed_byte_by_byte_and_with_garbage_between_frames() -> None:
    adc, _ = make()
    adc.exchange(b"\xff\x13\x37", 0)  # clocks with CS high: ignored by the part
    read(adc, b"\x00\x00\x00")  # a frame without a start bit: nothing happens
    read(adc, b"\x06")  # a frame cut short after the start bit: aborted
    for ch, code in enumerate(CODES):
        adc.select(5)
        rx = b"".join(adc.exchange(bytes([b]), 5) for b in fig61_request(ch))
        adc.deselect(5)
        assert fig61_decode(rx) == code
    assert adc.counters["bytes_while_deselected"] == 3
    assert adc.counters["aborted_conversions"] == 1
    assert adc.counters["conversions"] == 4


def test_linux_mcp320x_framing_one_byte_then_two_byte_read() -> None:
    # drivers/iio/adc/mcp320x.c: tx = start << 6 | !diff << 5 | ch << 2, then a separate
    # 2-byte read in the same message; result = rx0 << 4 | rx1 >> 4.
    adc, _ = make()
    for ch, code in enumerate(CODES):
        adc.select(0)
        adc.exchange(bytes([1 << 6 | 1 << 5 | ch << 2]), 0)
        rx = adc.exchange(b"\x00\x00", 0)
        adc.deselect(0)
        assert (rx[0] << 4 | rx[1] >> 4) == code


def test_gpiozero_framing() -> None:
    # gpiozero MCP3xxx._send for bits=12: (0b10000 | (not diff) << 3 | ch) << (bits + 2) as
    # 3 big-endian bytes; _read masks the last two received bytes to 12 bits.
    adc, _ = make()
    for ch, code in enumerate(CODES):
        word = (0b10000 | 1 << 3 | ch) << 14
        rx = read(adc, word.to_bytes(3, "big"))
        assert int.from_bytes(rx[-2:], "big") & 0xFFF == code


def test_pipelined_burst_with_cs_toggled() -> None:
    adc, pins = make()
    got = []
    for ch in range(4):
        adc.select(1000)
        got.append(fig61_decode(adc.exchange(fig61_request(ch), 1000)))
        adc.deselect(1000)
    assert got == CODES
    assert pins.calls == [(0, 1000), (1, 1000), (2, 1000), (3, 1000)]


def test_leading_zeros_and_lsb_first_trailer_then_zeros() -> None:
    adc, _ = make()
    code = CODES[0]
    # Start bit in the last bit of byte 0 (7 leading zeros), then clock 6 bytes.
    rx = read(adc, bytes([0x01, 0b10000000, 0, 0, 0, 0]))
    bits = "".join(f"{b:08b}" for b in rx)
    start = 7
    assert bits[: start + 6] == "0" * (start + 6)  # hi-Z (read as 0) through the sample clock
    assert bits[start + 6] == "0"  # null bit
    assert bits[start + 7 : start + 19] == f"{code:012b}"
    assert bits[start + 19 : start + 30] == f"{code:012b}"[::-1][1:]  # B1..B11
    assert set(bits[start + 30 :]) == {"0"}


def test_pseudo_differential_pairs() -> None:
    adc, _ = make([2.0, 1.5, 0.5, 3.0])
    expect = {0: quantize(0.5, 5.0), 1: 0, 2: 0, 3: quantize(2.5, 5.0)}
    for d, code in expect.items():
        assert fig61_decode(read(adc, fig61_request(d, single_ended=False))) == code
    ev = [e for e in adc.take_events() if isinstance(e, Mcp3204Conversion)]
    assert [(e.channel, e.single_ended) for e in ev] == [(0, False), (1, False), (2, False), (3, False)]
    assert ev[1].volts == -0.5 and ev[1].code == 0


def test_mode_3_works_and_wrong_phase_modes_shift_by_one_bit() -> None:
    adc, _ = make()
    for ch, code in enumerate(CODES):
        assert fig61_decode(read(adc, fig61_request(ch), mode=3)) == code
        for mode in (1, 2):
            got = fig61_decode(read(adc, fig61_request(ch), mode=mode))
            assert got == code >> 1  # the real part's data arrives one bit late
            if code > 1:
                assert got != code
    assert adc.counters["wrong_phase_spi_bytes"] == 4 * 2 * 3


def test_power_up_with_cs_low_needs_a_high_first() -> None:
    adc, _ = make(cs_low_at_power_up=True)
    rx = adc.exchange(fig61_request(0), 0)  # CS never raised since power-up
    assert rx == b"\x00\x00\x00"
    assert adc.counters["clocks_before_cs_raised"] == 24
    assert any(isinstance(e, Mcp3204ProtocolError) for e in adc.take_events())
    adc.select(0)  # already low: no falling edge, still ignored
    assert adc.exchange(fig61_request(0), 0) == b"\x00\x00\x00"
    adc.deselect(0)
    assert fig61_decode(read(adc, fig61_request(0))) == 3346


def test_cs_not_raised_between_conversions_reads_the_trailer_not_a_new_code() -> None:
    adc, _ = make()
    adc.select(0)
    first = adc.exchange(fig61_request(1), 0)
    second = adc.exchange(fig61_request(1), 0)
    third = adc.exchange(fig61_request(1), 0)
    adc.deselect(0)
    assert fig61_decode(first) == CODES[1]
    assert fig61_decode(third) == 0 and third == b"\x00\x00\x00"
    bits = f"{int.from_bytes(second, 'big'):024b}"
    assert bits[:11] == f"{CODES[1]:012b}"[::-1][1:]  # the LSB-first trailer, then zeros
    assert adc.counters["cs_not_raised_between_conversions"] == 1
    assert adc.counters["conversions"] == 1


def test_dummy_bytes_after_the_data_are_not_a_new_command() -> None:
    adc, _ = make()
    adc.select(0)
    adc.exchange(bytes([0x60]), 0)  # Linux framing, then a long read clocking 0xFF
    rx = adc.exchange(b"\xff" * 6, 0)
    adc.deselect(0)
    assert (rx[0] << 4 | rx[1] >> 4) == CODES[0]
    read(adc, fig61_request(0) + b"\x00" * 4)
    assert adc.counters["cs_not_raised_between_conversions"] == 0
    assert adc.counters["conversions"] == 2


def test_vref_is_settable_at_run_time() -> None:
    adc, _ = make([1.0, 0, 0, 0])
    assert fig61_decode(read(adc, fig61_request(0))) == 819
    adc.vref_V = 2.5
    assert fig61_decode(read(adc, fig61_request(0))) == 1638
    adc.vref_V = 0.0  # reference lost: the SAR DAC sits at 0, every comparison is "above"
    assert fig61_decode(read(adc, fig61_request(0))) == 4095
    assert adc.counters["vref_out_of_spec"] == 1


def test_conversion_event_fields_and_sampler_time() -> None:
    adc, pins = make()
    read(adc, fig61_request(2), t_ns=123_456)
    (ev,) = adc.take_events()
    assert ev == Mcp3204Conversion(123_456, 2, True, 2048, 2.5, 5.0)
    assert pins.calls == [(2, 123_456)]
    assert adc.counters["codes_ch2"] == 1


def test_bit_banged_pins_read_a_code() -> None:
    adc, _ = make()
    adc.set_pins(0, cs=0, sck=0, din=0)
    bits = []
    for bit in f"{int.from_bytes(fig61_request(0), 'big'):024b}":
        adc.set_pins(0, cs=0, sck=0, din=int(bit))
        dout = adc.set_pins(0, cs=0, sck=1, din=int(bit))
        bits.append(0 if dout is None else dout)
    adc.set_pins(0, cs=1, sck=0, din=0)
    assert int("".join(map(str, bits)), 2) & 0xFFF == 3346


@settings(deadline=None, max_examples=200)
@given(st.floats(min_value=0.0, max_value=5.0 - 1e-9), st.floats(min_value=0.5, max_value=5.5))
def test_voltage_code_voltage_within_one_lsb(v: float, vref: float) -> None:
    code = quantize(v, vref)
    if v < vref * 4095 / 4096:
        assert abs(code_center_V(code, vref) - v) <= lsb_V(vref)
    assert quantize(v + lsb_V(vref), vref) >= code  # monotonic


@settings(deadline=None, max_examples=100)
@given(st.binary(min_size=0, max_size=40), st.integers(0, 3), st.booleans())
def test_garbage_never_raises(data: bytes, mode: int, cs_low: bool) -> None:
    adc, _ = make()
    if cs_low:
        adc.select(0)
    rx = adc.exchange(data, 0, mode)
    assert len(rx) == len(data)


def frame_oracle(mosi_bits: list[int], volts: list[float]) -> list[int]:
    """MISO bits of one CS-low frame in mode 0,0 from the datasheet's bit table alone."""
    out = [0] * len(mosi_bits)
    if 1 not in mosi_bits:
        return out
    s = mosi_bits.index(1)
    if len(mosi_bits) < s + 6:
        return out
    sgl, d1, d0 = mosi_bits[s + 1], mosi_bits[s + 3], mosi_bits[s + 4]
    ch = d1 << 1 | d0
    vin = volts[ch] if sgl else volts[ch] - volts[{0: 1, 1: 0, 2: 3, 3: 2}[ch]]
    code = quantize(vin, 5.0)
    stream = [0] + [int(c) for c in f"{code:012b}"] + [int(c) for c in f"{code:012b}"[::-1][1:]]
    for i, bit in enumerate(stream):
        if s + 6 + i < len(out):
            out[s + 6 + i] = bit
    return out


class FrameMachine(RuleBasedStateMachine):
    """Arbitrary fragmentation of frames in mode 0 or 3 against the bit-table oracle."""

    def __init__(self) -> None:
        super().__init__()
        self.pins = Pins([1.0, 2.0, 3.0, 4.0])
        self.adc = Mcp3204(Mcp3204Params(), self.pins)
        self.mode = 0
        self.mosi: list[int] = []
        self.miso: list[int] = []
        self.frame_volts = list(self.pins.volts)

    @precondition(lambda self: not self.adc.cs_low)
    @rule(mode=st.sampled_from([0, 3]))
    def select(self, mode: int) -> None:
        self.mode = mode
        self.adc.set_sck(mode >> 1, 0)  # the master sets its idle clock before CS falls
        self.adc.select(0)
        self.mosi, self.miso = [], []
        self.frame_volts = list(self.pins.volts)

    @rule()
    def deselect(self) -> None:
        self.adc.deselect(0)

    @precondition(lambda self: self.adc.cs_low)
    @rule(data=st.binary(min_size=1, max_size=4))
    def exchange(self, data: bytes) -> None:
        rx = self.adc.exchange(data, 0, self.mode)
        for a, b in zip(data, rx):
            self.mosi += [int(c) for c in f"{a:08b}"]
            self.miso += [int(c) for c in f"{b:08b}"]

    @precondition(lambda self: not self.adc.cs_low)
    @rule(ch=st.integers(0, 3), v=st.floats(0.0, 5.0))
    def set_voltage(self, ch: int, v: float) -> None:
        self.pins.volts[ch] = v

    @invariant()
    def matches_oracle(self) -> None:
        assert self.miso == frame_oracle(self.mosi, self.frame_volts)


TestFrameMachine = FrameMachine.TestCase
TestFrameMachine.settings = settings(max_examples=60, stateful_step_count=30, deadline=None)
