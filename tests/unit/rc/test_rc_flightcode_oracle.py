"""Contract: the flight code's decoders (used here only as an oracle) read what the RC and
Maestro emulators produce and send."""

from __future__ import annotations

import numpy as np

from emulators.maestro import Maestro, MaestroParams, TargetsSet
from emulators.rc import (
    CaptureFrontEnd,
    CaptureParams,
    PpmGenerator,
    PpmParams,
    SbusConverter,
    SbusParams,
)
from emulators.rc.script import Setpoint, StickScript
from flightcode.drivers import maestro as fc_maestro
from flightcode.drivers import ppm_capture as fc_capture
from flightcode.drivers import sbus as fc_sbus

TICK_NS = 2_500_000
SCRIPT = StickScript([Setpoint(0.0, 1, 1200), Setpoint(0.0, 2, 1800), Setpoint(0.0, 3, 1050),
                      Setpoint(0.0, 4, 1950), Setpoint(0.0, 5, 2000)])
WANT = (1200, 1800, 1050, 1950, 2000, 1000, 1000, 1000)


def stream(frontend, seconds: float) -> bytes:  # type: ignore[no-untyped-def]
    gen = PpmGenerator(PpmParams(), np.random.default_rng(9), SCRIPT)
    out = bytearray()
    for k in range(int(seconds * 400) + 1):
        t = k * TICK_NS
        frontend.feed_edges(gen.edges_until(t))
        frontend.advance(t)
        out += frontend.take_output()
    return bytes(out)


def test_flightcode_capture_decoder_reads_the_front_end() -> None:
    data = stream(CaptureFrontEnd(CaptureParams()), 1.5)
    parser = fc_capture.CaptureParser()
    decoder = fc_capture.PpmDecoder(fc_capture.PpmParams())
    frames = []
    for i in range(0, len(data), 7):  # odd-sized chunks: records split across reads
        for rec in parser.feed(data[i:i + 7]):
            frame = decoder.record(rec)
            if frame is not None:
                frames.append(frame)
    assert parser.counters["crc_errors"] == 0 and parser.counters["garbage_bytes"] == 0
    assert len(frames) >= 30  # 66 frames in 1.5 s, minus the 25-frame lock and the first sync
    for f in frames:
        assert len(f) == 8 and all(abs(a - b) <= 5 for a, b in zip(f, WANT))


def test_flightcode_sbus_parser_reads_the_converter() -> None:
    data = stream(SbusConverter(SbusParams()), 0.5)
    frames = fc_sbus.SbusParser().feed(data)
    assert len(frames) == 36
    good = [f for f in frames if not f.flags & 0x0C]
    assert len(good) >= 30
    for f in good:
        us = [r * 0.625 + 875 for r in f.raw[:8]]
        assert all(abs(a - b) <= 4.5 for a, b in zip(us, WANT))


def test_maestro_decodes_the_flightcode_command() -> None:
    m = Maestro(MaestroParams())
    pulses = (1000.0, 1234.5, 1500.25, 2000.0)
    m.receive(fc_maestro.set_multiple_targets(0, [fc_maestro.quarter_us(p) for p in pulses]), 0)
    (ev,) = [e for e in m.take_events() if isinstance(e, TargetsSet)]
    assert ev.first_channel == 0 and ev.targets_qus == (4000, 4938, 6001, 8000)
    assert [m.pulse_us(c, 0) for c in range(4)] == [1000.0, 1234.5, 1500.25, 2000.0]
