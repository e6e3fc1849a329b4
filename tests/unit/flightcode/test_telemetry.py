"""Telemetry payload: round trip through a decoder written from docs/telemetry.md, and the XBee frame."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode import telemetry
from flightcode.drivers.xbee import api_frame, tx16
from flightcode.telemetry import ComputeWindow, TelemetryRecord
from tests.unit.flightcode.fakes import xbee_frames

# (offset, struct code, name) exactly as the table in docs/telemetry.md
DOC_TABLE = [
    (0, "B", "version"), (1, "B", "mode"), (2, "H", "seq"), (4, "I", "t_100us"), (8, "H", "flags"),
    (10, "f", "roll_rad"), (14, "f", "pitch_rad"), (18, "f", "yaw_rad"), (22, "f", "z_hat_m"),
    (26, "f", "vz_hat_mps"), (30, "f", "z_baro_m"), (34, "f", "roll_ref_rad"), (38, "f", "pitch_ref_rad"),
    (42, "f", "yaw_rate_ref_radps"), (46, "f", "z_ref_m"), (50, "H", "motor0_qus"), (52, "H", "motor1_qus"),
    (54, "H", "motor2_qus"), (56, "H", "motor3_qus"), (58, "f", "collective"), (62, "f", "tau_roll_Nm"),
    (66, "f", "tau_pitch_Nm"), (70, "f", "tau_yaw_Nm"), (74, "H", "compute_last_us"), (76, "H", "compute_max_us"),
    (78, "H", "compute_mean_us"), (80, "H", "imu_gap_samples"), (82, "H", "imu_skipped_samples"),
    (84, "H", "adc_failed_reads"), (86, "H", "rc_errors"), (88, "H", "telemetry_dropped"),
]
DOC_LENGTH = 90


def decode_doc(payload: bytes) -> dict[str, float]:
    """The reference decoder: field by field from the documented offsets, little-endian."""
    assert len(payload) == DOC_LENGTH
    assert payload[0] == 1, "unknown version"
    return {name: struct.unpack_from("<" + code, payload, off)[0] for off, code, name in DOC_TABLE}


def test_doc_table_is_contiguous() -> None:
    end = 0
    for off, code, _ in DOC_TABLE:
        assert off == end
        end += struct.calcsize(code)
    assert end == DOC_LENGTH == telemetry.PAYLOAD_LEN <= 100


def _record(**changes: object) -> TelemetryRecord:
    base = dict(seq=7, t_ns=1_250_000_000, mode=3, flags=0x000B, euler_rad=(0.0, 0.0, 0.0), z_hat_m=2.0,
                vz_hat_mps=0.0, z_baro_m=2.1, roll_ref_rad=0.0, pitch_ref_rad=0.0, yaw_rate_ref_radps=0.0,
                z_ref_m=2.0, pulses_us=(1724.0, 1724.0, 1724.0, 1724.0), collective=0.724,
                tau_applied_Nm=(0.0, 0.0, 0.0), compute_last_us=95.0, compute_max_us=140.0, compute_mean_us=101.4,
                imu_gap_samples=0, imu_skipped_samples=0, adc_failed_reads=0, rc_errors=0, telemetry_dropped=0)
    base.update(changes)
    return TelemetryRecord(**base)  # type: ignore[arg-type]


def test_worked_example_bytes() -> None:
    payload = telemetry.encode(_record())
    assert payload[:14] == bytes.fromhex("01 03 07 00 D4 30 00 00 0B 00 00 00 00 00")
    assert payload[22:26] == bytes.fromhex("00 00 00 40")
    assert payload[50:52] == bytes.fromhex("F0 1A")


f32 = st.floats(-1e6, 1e6, allow_nan=False, width=32)


@settings(max_examples=80, deadline=None)
@given(seq=st.integers(0, 10**6), t_ns=st.integers(0, 10**15), mode=st.integers(0, 5), flags=st.integers(0, 0x7F),
       e=st.tuples(f32, f32, f32), z=st.tuples(f32, f32, f32), refs=st.tuples(f32, f32, f32, f32),
       pulses=st.tuples(*[st.floats(0.0, 16383.75)] * 4), tau=st.tuples(f32, f32, f32),
       compute=st.tuples(*[st.floats(0.0, 1e6)] * 3), counts=st.tuples(*[st.integers(0, 10**7)] * 5))
def test_round_trip_through_the_reference_decoder(seq: int, t_ns: int, mode: int, flags: int, e: tuple, z: tuple,
                                                   refs: tuple, pulses: tuple, tau: tuple, compute: tuple,
                                                   counts: tuple) -> None:
    rec = TelemetryRecord(seq, t_ns, mode, flags, e, z[0], z[1], z[2], *refs, pulses, refs[0] / 2, tau,
                          *compute, *counts)
    d = decode_doc(telemetry.encode(rec))
    assert d["seq"] == seq % 65536 and d["t_100us"] == (t_ns // 100_000) % 2**32
    assert (d["mode"], d["flags"]) == (mode, flags)
    assert (d["roll_rad"], d["pitch_rad"], d["yaw_rad"]) == pytest.approx(e, rel=1e-6, abs=1e-30)
    assert (d["z_hat_m"], d["vz_hat_mps"], d["z_baro_m"]) == pytest.approx(z, rel=1e-6, abs=1e-30)
    assert (d["roll_ref_rad"], d["pitch_ref_rad"], d["yaw_rate_ref_radps"], d["z_ref_m"]) == pytest.approx(
        refs, rel=1e-6, abs=1e-30)
    for i in range(4):
        assert d[f"motor{i}_qus"] / 4 == pytest.approx(pulses[i], abs=0.125)
    assert (d["tau_roll_Nm"], d["tau_pitch_Nm"], d["tau_yaw_Nm"]) == pytest.approx(tau, rel=1e-6, abs=1e-30)
    for name, value in zip(("compute_last_us", "compute_max_us", "compute_mean_us"), compute):
        assert d[name] == min(65535, round(value))
    names = ("imu_gap_samples", "imu_skipped_samples", "adc_failed_reads", "rc_errors", "telemetry_dropped")
    for name, value in zip(names, counts):
        assert d[name] == value % 65536


def test_missing_baro_is_nan() -> None:
    assert math.isnan(decode_doc(telemetry.encode(_record(z_baro_m=math.nan)))["z_baro_m"])


@pytest.mark.parametrize("escaped", [False, True])
def test_payload_in_an_xbee_tx16_frame(escaped: bool) -> None:
    payload = telemetry.encode(_record(seq=0x7E13))  # bytes that need escaping in AP=2
    frame = api_frame(tx16(0, 0x0001, payload), escaped)
    assert frame[:8] == bytes.fromhex("7E 00 5F 01 00 00 01 00") or escaped
    (data,) = xbee_frames(frame, escaped)
    assert data[:5] == bytes.fromhex("01 00 00 01 00") and decode_doc(data[5:])["seq"] == 0x7E13


def test_compute_window() -> None:
    w = ComputeWindow()
    for ns in (100_000, 300_000, 200_000):
        w.add(ns)
    assert w.take() == (200.0, 300.0, 200.0)
    w.add(50_000)
    assert w.take() == (50.0, 50.0, 50.0)
    assert w.take() == (50.0, 0.0, 0.0)
