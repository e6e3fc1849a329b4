"""Maestro: golden packets (Pololu 0J40 section 5), replies, errors, CRC-7, Mini SSC, motion."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.maestro import (
    Command,
    ErrorBit,
    Maestro,
    MaestroParams,
    ProtocolError,
    TargetsSet,
    compact,
    crc7,
    get_position,
    mini_ssc,
    pololu,
    set_multiple_targets,
    set_target,
)

# Worked examples of docs/protocols.md 6.2, verified against Pololu 0J40 5.c/5.e.
GOLDEN_SET_TARGET_CH0 = bytes.fromhex("84 00 70 2E")  # 0J40 5.c: ch0 1500 us
GOLDEN_SET_TARGET_CH2 = bytes.fromhex("84 02 70 2E")  # 0J40 5.e: ch2 1500 us
GOLDEN_POLOLU_CH0 = bytes.fromhex("AA 0C 04 00 70 2E")  # 0J40 5.c Pololu form
GOLDEN_MINI_SSC_NEUTRAL = bytes.fromhex("FF 00 7F")
GOLDEN_MULTI = bytes.fromhex("9F 02 03 00 00 70 2E")  # 0J40 5.e: ch3 = 0, ch4 = 6000


def dev(**kw: object) -> Maestro:
    return Maestro(MaestroParams(**kw))  # type: ignore[arg-type]


def targets(m: Maestro) -> list[tuple[int, tuple[int, ...]]]:
    return [(e.first_channel, e.targets_qus) for e in m.take_events() if isinstance(e, TargetsSet)]


@pytest.mark.parametrize("mode", ["whole", "bytewise", "garbage_before"])
def test_golden_packets_decoded(mode: str) -> None:
    m = dev()
    packets = [GOLDEN_SET_TARGET_CH0, GOLDEN_SET_TARGET_CH2, GOLDEN_POLOLU_CH0, GOLDEN_MINI_SSC_NEUTRAL, GOLDEN_MULTI]
    stream = b"".join(packets)
    if mode == "whole":
        m.receive(stream, 0)
    elif mode == "bytewise":
        for b in stream:
            m.receive(bytes([b]), 0)
    else:
        m.receive(b"\x01\x02", 0)  # stray data bytes: protocol error, channels home (off)
        assert m.errors == ErrorBit.SERIAL_PROTOCOL
        m.receive(stream, 0)
    got = targets(m)
    assert got == [(0, (6000,)), (2, (6000,)), (0, (6000,)), (0, (6000,)), (3, (0, 6000))]
    assert m.pulse_us(0, 0) == 1500.0 and m.pulse_us(3, 0) == 0.0 and m.pulse_us(4, 0) == 1500.0
    assert m.counters["commands"] == 5


def test_builders_produce_golden_bytes() -> None:
    assert set_target(0, 6000) == GOLDEN_SET_TARGET_CH0
    assert set_target(2, 6000) == GOLDEN_SET_TARGET_CH2
    assert pololu(12, Command.SET_TARGET, bytes([0, 0x70, 0x2E])) == GOLDEN_POLOLU_CH0
    assert mini_ssc(0, 127) == GOLDEN_MINI_SSC_NEUTRAL
    assert set_multiple_targets(3, [0, 6000]) == GOLDEN_MULTI


def test_get_position_reply_little_endian() -> None:
    m = dev()
    m.receive(set_target(5, 7000), 0)  # 1750 us = 7000 = 0x1B58
    m.receive(get_position(5), 0)
    assert m.take_output() == bytes([0x58, 0x1B])
    m.receive(pololu(12, Command.GET_POSITION, b"\x05"), 0)
    assert m.take_output() == bytes([0x58, 0x1B])


def test_targets_clamped_and_zero_is_off() -> None:
    m = dev()
    m.receive(set_target(0, 2000) + set_target(1, 9000) + set_target(2, 0), 0)
    assert targets(m) == [(0, (3968,)), (1, (8000,)), (2, (0,))]
    assert m.pulse_us(0, 0) == 992.0 and m.pulse_us(1, 0) == 2000.0 and m.pulse_us(2, 0) == 0.0


def test_other_pololu_device_ignored() -> None:
    m = dev()
    m.receive(pololu(13, Command.SET_TARGET, bytes([0, 0x70, 0x2E])), 0)
    m.receive(pololu(13, Command.GET_ERRORS), 0)
    assert targets(m) == [] and m.take_output() == b"" and m.errors == 0
    assert m.counters["packets_other_device"] == 2


def test_get_errors_reports_then_clears() -> None:
    m = dev()
    m.receive(b"\x42", 0)  # data byte where a command was expected
    m.receive(bytes([0x84, 0x00, 0x70]) + bytes([Command.GET_ERRORS]), 0)  # interrupted packet
    assert m.take_output() == bytes([0x10, 0x00])
    m.receive(bytes([Command.GET_ERRORS]), 0)
    assert m.take_output() == b"\x00\x00"
    m.receive(b"\x80", 0)  # unknown command
    m.receive(pololu(12, Command.GET_ERRORS), 0)
    assert m.take_output() == bytes([0x10, 0x00])
    errs = [e for e in m.take_events() if isinstance(e, ProtocolError)]
    assert [e.error_bits for e in errs] == [0x10, 0x10, 0x10]


def test_error_sends_channels_home() -> None:
    m = dev()
    m.receive(set_multiple_targets(0, [6000] * 4), 0)
    assert all(m.pulse_us(c, 0) == 1500.0 for c in range(4))
    m.receive(b"\x00", 1_000_000)
    assert all(m.pulse_us(c, 1_000_000) == 0.0 for c in range(4))
    m2 = dev(home_on_error=False)
    m2.receive(set_target(0, 6000) + b"\x00", 0)
    assert m2.pulse_us(0, 0) == 1500.0


def test_crc7_golden_and_mode() -> None:
    assert crc7(bytes([0x83, 0x01])) == 0x17  # Pololu 0J40 5.d worked example
    m = dev(crc_enabled=True)
    m.receive(set_target(0, 6000, crc=True), 0)
    assert targets(m) == [(0, (6000,))]
    bad = bytearray(set_target(1, 6000, crc=True))
    bad[-1] ^= 0x01
    m.receive(bytes(bad), 0)
    assert targets(m) == [] and m.errors & ErrorBit.SERIAL_CRC
    m.receive(compact(Command.GET_ERRORS, crc=True), 0)
    assert int.from_bytes(m.take_output(), "little") & ErrorBit.SERIAL_CRC  # no CRC on replies
    m.receive(pololu(12, Command.GET_POSITION, b"\x00", crc=True), 0)
    assert m.take_output() == b"\x00\x00"  # channel 0 went home (off) on the CRC error


def test_mini_ssc_mapping_and_offset() -> None:
    m = dev(mini_ssc_offset=10)
    m.receive(mini_ssc(10, 0) + mini_ssc(11, 254) + mini_ssc(12, 127) + mini_ssc(3, 127), 0)
    # neutral 1500 us -+ 476.25 us range.
    assert targets(m) == [(0, (4095,)), (1, (7905,)), (2, (6000,))]
    assert m.counters["mini_ssc_other_address"] == 1


def test_mini_ssc_data_may_look_like_commands() -> None:
    m = dev()
    m.receive(bytes([0xFF, 0x01, 0xA1]), 0)  # 0xA1 is a Mini SSC value here, not Get Errors
    assert m.take_output() == b""
    assert targets(m) == [(1, (round(6000 + (0xA1 - 127) * 1905 / 127),))]


def test_bad_channel_and_multi_overflow_are_protocol_errors() -> None:
    m = dev(n_channels=6)
    m.receive(set_target(6, 6000), 0)
    m.receive(set_multiple_targets(4, [6000, 6000, 6000]), 0)
    assert targets(m) == [] and m.errors == ErrorBit.SERIAL_PROTOCOL


def test_speed_limit_in_sim_time() -> None:
    m = dev()
    m.receive(set_target(0, 6000), 0)
    m.receive(compact(Command.SET_SPEED, bytes([0, 40, 0])), 0)  # 40 qus / 10 ms = 1 us/ms
    m.receive(set_target(0, 8000), 0)  # +500 us -> 500 ms
    assert m.pulse_us(0, 0) == 1500.0
    m.receive(bytes([Command.GET_MOVING_STATE]), 0)
    assert m.take_output() == b"\x01"
    assert m.pulse_us(0, 100_000_000) == pytest.approx(1600.0)
    assert m.pulse_us(0, 499_000_000) == pytest.approx(1990.0)
    assert m.pulse_us(0, 500_000_000) == 2000.0
    m.receive(bytes([Command.GET_MOVING_STATE]), 500_000_000)
    assert m.take_output() == b"\x00"


def test_acceleration_limit_ramps_speed() -> None:
    m = dev()
    m.receive(set_target(1, 4000), 0)
    m.receive(compact(Command.SET_ACCELERATION, bytes([1, 8, 0])), 0)  # +1 qus/10ms per 10 ms
    m.receive(set_target(1, 8000), 0)
    steps = [m.channels[1].position_qus]
    for k in range(1, 6):
        m.advance(k * 10_000_000)
        steps.append(m.channels[1].position_qus)
    assert [b - a for a, b in zip(steps, steps[1:])] == [1, 2, 3, 4, 5]
    m.advance(5_000_000_000)
    assert m.channels[1].position_qus == 8000 and not m.channels[1].moving


def test_first_target_from_off_is_immediate() -> None:
    m = dev()
    m.receive(compact(Command.SET_SPEED, bytes([0, 1, 0])) + set_target(0, 7000), 0)
    assert m.pulse_us(0, 0) == 1750.0


def test_go_home_and_script_status() -> None:
    m = dev(home_qus=4000)
    m.receive(set_target(0, 6000) + bytes([Command.GO_HOME, Command.GET_SCRIPT_STATUS]), 0)
    assert m.pulse_us(0, 0) == 1000.0 and m.take_output() == b"\x01"


def test_serial_timeout() -> None:
    m = dev(serial_timeout_ms=100)
    m.receive(set_target(0, 6000), 0)
    m.advance(99_000_000)
    assert m.pulse_us(0, 99_000_000) == 1500.0
    m.advance(100_000_000)
    assert m.errors & ErrorBit.SERIAL_TIMEOUT and m.pulse_us(0, 100_000_000) == 0.0


def test_uart_wrong_baud_is_signal_error() -> None:
    m = dev(usb_command_port=False, baud=115200)
    m.line_settings_changed(9600, 0)
    m.receive(set_target(0, 6000), 0)
    assert targets(m) == [] and m.errors & ErrorBit.SERIAL_SIGNAL
    usb = dev()
    usb.line_settings_changed(9600, 0)
    usb.receive(set_target(0, 6000), 0)
    assert targets(usb) == [(0, (6000,))]


@given(st.binary(max_size=200))
@settings(max_examples=150, deadline=None)
def test_any_bytes_never_crash_and_resync(garbage: bytes) -> None:
    m = dev(crc_enabled=False)
    m.receive(garbage, 0)
    m.take_output()
    # A Mini SSC packet resynchronises from any state: 0xFF interrupts whatever was in
    # progress (or restarts an unfinished Mini SSC packet) and the two data bytes finish it.
    m.receive(mini_ssc(0, 127) + set_target(0, 6000) + get_position(0), 0)
    assert m.take_output() == bytes([0x70, 0x17])
