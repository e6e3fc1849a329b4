"""The firmware's telemetry payload (firmware/src/telemetry.c) is flightcode's version 1, byte
for byte, for any record (docs/telemetry.md): the bench decodes both with one decoder."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.telemetry import PAYLOAD_LEN, TelemetryRecord, encode
from tests.unit.firmware.fwcodecs import Codecs, TelemetryRecordT


@pytest.fixture(scope="module")
def fw(tmp_path_factory: pytest.TempPathFactory) -> Codecs:
    return Codecs(tmp_path_factory.mktemp("codecs"))


f32 = st.floats(-1e6, 1e6, width=32)
pulse = st.floats(0.0, 20000.0, width=32)
dur = st.one_of(st.floats(0.0, 70000.0, width=32), st.just(math.nan))
count = st.integers(0, 2**32 - 1)


@settings(max_examples=300, deadline=None)
@given(seq=count, t_ns=st.integers(0, 2**42), mode=st.integers(0, 5), flags=st.integers(0, 0xFFFF),
       floats=st.lists(f32, min_size=14, max_size=14), z_baro=st.one_of(f32, st.just(math.nan)),
       pulses=st.lists(pulse, min_size=4, max_size=4), durs=st.lists(dur, min_size=3, max_size=3),
       counts=st.lists(count, min_size=5, max_size=5))
def test_payload_is_flightcodes(fw: Codecs, seq: int, t_ns: int, mode: int, flags: int, floats: list[float],
                                z_baro: float, pulses: list[float], durs: list[float], counts: list[int]) -> None:
    py = TelemetryRecord(seq, t_ns, mode, flags, tuple(floats[0:3]), floats[3], floats[4], z_baro, floats[5],
                         floats[6], floats[7], floats[8], tuple(pulses), floats[9], tuple(floats[10:13]), *durs,
                         *counts)
    c = TelemetryRecordT()
    c.seq, c.t_ns, c.mode, c.flags = seq, t_ns, mode, flags
    c.euler_rad[:] = floats[0:3]
    c.z_hat_m, c.vz_hat_mps, c.z_baro_m = floats[3], floats[4], z_baro
    c.roll_ref_rad, c.pitch_ref_rad, c.yaw_rate_ref_radps, c.z_ref_m = floats[5:9]
    c.pulses_us[:] = pulses
    c.collective = floats[9]
    c.tau_applied_Nm[:] = floats[10:13]
    c.compute_last_us, c.compute_max_us, c.compute_mean_us = durs
    (c.imu_gap_samples, c.imu_skipped_samples, c.adc_failed_reads, c.rc_errors, c.telemetry_dropped) = counts
    # the pulses and durations are float32 in the firmware: round them as it holds them
    py = py.__class__(**{**py.__dict__, "pulses_us": tuple(float(np.float32(p)) for p in pulses)})
    out = fw.telemetry(c)
    assert len(out) == PAYLOAD_LEN
    assert out == encode(py)
