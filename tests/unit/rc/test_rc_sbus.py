"""SBUS front-end: codec (golden frame, round trips), PPM decoding, period, flags."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.rc.params import PpmParams, SbusParams
from emulators.rc.ppm import PpmGenerator
from emulators.rc.sbus import (
    PpmDecoder,
    SbusConverter,
    SbusFrame,
    pack_sbus,
    pwm_to_raw,
    raw_to_pwm,
    unpack_sbus,
)
from emulators.rc.script import Loss, Setpoint, StickScript

MS = 1_000_000

# docs/protocols.md 5.2: all 16 channels raw 992, no flags (layout of ArduPilot
# AP_RCProtocol_SBUS.cpp: 0x0F, 16 x 11 bits LSB first, flags, end 0x00).
GOLDEN_992 = bytes.fromhex("0F E0 03 1F F8 C0 07 3E F0 81 0F 7C E0 03 1F F8 C0 07 3E F0 81 0F 7C 00 00")


def test_golden_all_992_both_ways() -> None:
    frame = SbusFrame((992,) * 16)
    assert pack_sbus(frame) == GOLDEN_992
    assert unpack_sbus(GOLDEN_992) == frame


def test_flag_bits() -> None:
    wire = pack_sbus(SbusFrame((992,) * 16, ch17=True, frame_lost=True, failsafe=True))
    assert wire[23] == 0x01 | 0x04 | 0x08
    assert unpack_sbus(wire[:-1]) is None and unpack_sbus(b"\x0e" + wire[1:]) is None


@given(st.lists(st.integers(0, 0x7FF), min_size=16, max_size=16), st.booleans(), st.booleans(),
       st.booleans(), st.booleans(), st.integers(0, 255))
@settings(max_examples=150, deadline=None)
def test_round_trip(ch: list[int], c17: bool, c18: bool, lost: bool, fs: bool, end: int) -> None:
    frame = SbusFrame(tuple(ch), c17, c18, lost, fs, end)
    wire = pack_sbus(frame)
    assert len(wire) == 25 and wire[0] == 0x0F
    assert unpack_sbus(wire) == frame


def test_ardupilot_scaling() -> None:
    assert raw_to_pwm(200) == 1000 and raw_to_pwm(1800) == 2000
    assert raw_to_pwm(992) == 1495 and abs(raw_to_pwm(1811) - 2006.875) < 1e-9
    assert pwm_to_raw(1500) == 1000 and pwm_to_raw(1000) == 200 and pwm_to_raw(2000) == 1800


@given(st.integers(1000, 2000))
@settings(max_examples=200, deadline=None)
def test_scaling_inverse_within_resolution(pwm: int) -> None:
    assert abs(raw_to_pwm(pwm_to_raw(pwm)) - pwm) <= 0.3125


def run(script: StickScript, until_ns: int, ppm: PpmParams | None = None,
        params: SbusParams | None = None, faults=None) -> tuple[SbusConverter, list[tuple[int, SbusFrame]]]:
    gen = PpmGenerator(ppm or PpmParams(), np.random.default_rng(2), script)
    if faults:
        faults(gen)
    conv = SbusConverter(params or SbusParams())
    frames: list[tuple[int, SbusFrame]] = []
    for t in range(0, until_ns + 1, 2_500_000):
        conv.feed_edges(gen.edges_until(t))
        conv.advance(t)
        out = conv.take_output()
        assert len(out) % 25 == 0
        for i in range(0, len(out), 25):
            f = unpack_sbus(out[i:i + 25])
            assert f is not None
            frames.append((t, f))
    return conv, frames


SCRIPT = StickScript([Setpoint(0.0, 1, 1100), Setpoint(0.0, 2, 1900), Setpoint(0.0, 3, 1300)])


def test_period_and_channels() -> None:
    conv, frames = run(SCRIPT, 1_000 * MS)
    assert conv.counters["frames"] == 1000 // 14 + 1  # frames at 0, 14, ..., 994 ms
    good = [f for _, f in frames if not f.failsafe]
    assert len(good) > 60 and not any(f.frame_lost for f in good)
    for f in good:
        pwm = [raw_to_pwm(r) for r in f.channels_raw]
        want = [1100, 1900, 1300, 1500, 1000, 1000, 1000, 1000] + [1500] * 8
        assert all(abs(a - b) <= 4.5 for a, b in zip(pwm, want))  # 2 x 2 us jitter + scaling
    # At power-up, before the first decoded PPM frame, the converter is in failsafe.
    assert frames[0][1].failsafe and frames[0][1].frame_lost


def test_loss_raises_frame_lost_then_failsafe_then_recovers() -> None:
    script = StickScript([Setpoint(0.0, 3, 1300), Loss(0.5, 1.5)])
    _, frames = run(script, 2_500 * MS)
    by_t = {t: f for t, f in frames}

    def at(ms: int) -> SbusFrame:
        return by_t[min(t for t in by_t if t >= ms * MS)]

    assert not at(400).frame_lost
    # Last PPM frame before the loss ends ~ 0.5 s; frame lost after 34 ms of nothing.
    assert at(560).frame_lost and not at(560).failsafe
    assert at(1_000 + 540).failsafe and at(1_000 + 540).frame_lost
    # Held values during loss.
    assert abs(raw_to_pwm(at(1_600).channels_raw[2]) - 1300) <= 1.5
    assert not at(2_200).failsafe and not at(2_200).frame_lost


def test_glitch_leaving_a_short_piece_drops_the_frame() -> None:
    # Channel 3 = 1300 us split at 650 us: pieces 790 and 510 us; 510 < 700 -> frame invalid.
    conv, frames = run(SCRIPT, 400 * MS, faults=lambda g: g.inject_glitch(200 * MS, 20, 3))
    assert conv.decoder.frames_bad == 1
    assert all(abs(raw_to_pwm(f.channels_raw[2]) - 1300) <= 4.5 for _, f in frames if not f.failsafe)


def test_glitch_leaving_valid_pieces_corrupts_one_frame() -> None:
    # Channel 2 = 1900 us split at 1100 us: pieces 1090 and 810 us are both "valid", so an
    # ArduPilot-style decoder publishes one 9-channel frame: the converter passes it on.
    conv, _ = run(SCRIPT, 400 * MS, faults=lambda g: g.inject_glitch(200 * MS, 20, 2))
    lengths = [len(e.pulses_us) for e in conv.take_events()]
    assert lengths.count(9) == 1 and set(lengths) == {8, 9}


def test_channel_count_change_is_followed() -> None:
    conv, frames = run(SCRIPT, 400 * MS, faults=lambda g: g.set_channel_count(200 * MS, 6))
    late = [f for t, f in frames if t > 260 * MS]
    # Channels 7 and 8 no longer carried: the converter fills them with 1500 us.
    assert all(abs(raw_to_pwm(f.channels_raw[6]) - 1500) <= 1 for f in late)
    events = conv.take_events()
    assert {len(e.pulses_us) for e in events} == {8, 6}


def test_too_few_channels_rejected() -> None:
    conv, frames = run(SCRIPT, 300 * MS, ppm=PpmParams(n_channels=4))
    assert all(f.failsafe for _, f in frames)
    assert conv.counters["ppm_frames_ok"] == 0


def test_decoder_polarity_independent() -> None:
    for idle_high in (True, False):
        gen = PpmGenerator(PpmParams(idle_high=idle_high), np.random.default_rng(0), SCRIPT)
        dec = PpmDecoder(2700, 700, 2300, 5)
        got = [r for e in gen.edges_until(200 * MS) if (r := dec.edge(e.t_ns)) is not None]
        assert got and all(abs(a - b) <= 4 for a, b in zip(got[-1], (1100, 1900, 1300, 1500, 1000, 1000, 1000, 1000)))


def test_host_bytes_ignored_and_baud_counted() -> None:
    conv = SbusConverter(SbusParams())
    conv.receive(b"\x0f\x00", 0)
    conv.line_settings_changed(115200, 0)
    conv.line_settings_changed(100000, 0)
    assert conv.counters["rx_ignored_bytes"] == 2 and conv.counters["baud_mismatch"] == 1
