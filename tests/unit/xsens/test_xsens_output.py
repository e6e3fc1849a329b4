"""What the device sends while measuring: time stamps, counters, frames, precisions, errors."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from emulators.xsens.codec import Frame
from emulators.xsens.defs import MID, LegacyMode, Precision, StatusFlag
from emulators.xsens.events import SampleSent
from emulators.xsens.frames import euler_deg_to_quat, quat_to_matrix, rotate_inv
from emulators.xsens.mtdata2 import decode_values, unpack_packets
from emulators.xsens.params import Identity, XsensParams
from tests.unit.xsens.host import Host, exact_params

FLIGHT = [(0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2034, 400), (0x8024, 400), (0x4024, 400), (0xE020, 0xFFFF)]
G = 9.80665


def configured(entries: list[tuple[int, int]], params: XsensParams | None = None) -> Host:
    h = Host.make(params or exact_params())
    h.ask(MID.GOTO_CONFIG)
    h.ask(MID.SET_OUTPUT_CONFIGURATION, b"".join(struct.pack(">HH", x, f) for x, f in entries))
    h.ask(MID.GOTO_MEASUREMENT, t_ns=-500_000_000)
    return h


def packets(f: Frame) -> dict[int, bytes]:
    return dict(unpack_packets(f.payload))


def values(f: Frame, xdi: int) -> tuple[float, ...]:
    return decode_values(packets(f)[xdi], Precision(xdi & 0x3))


# -- time and counters ----------------------------------------------------------------------------

def test_400hz_grid_sample_time_fine_and_packet_counter() -> None:
    h = configured(FLIGHT)
    assert h.dev.output_period_ns == 2_500_000
    h.advance(997_500_000)
    sent = h.of_type(SampleSent)
    assert [e.t_ns for e in sent] == [k * 2_500_000 for k in range(400)]
    assert [e.packet_counter for e in sent] == list(range(400))
    assert [e.sample_time_fine for e in sent] == [25 * k for k in range(400)]


def test_advance_emits_every_instant_in_the_half_open_interval_once() -> None:
    h = configured(FLIGHT)
    h.advance(-1)
    h.advance(0)
    h.advance(0)
    h.advance(2_499_999)
    h.advance(7_500_000)
    h.advance(5_000_000)  # time never goes backwards
    assert [e.t_ns for e in h.of_type(SampleSent)] == [0, 2_500_000, 5_000_000, 7_500_000]


def test_sample_time_fine_offset_and_wrap() -> None:
    offset = (1 << 32) * 100_000 - 250_000
    h = configured(FLIGHT, exact_params(power_on_offset_ns=offset))
    h.advance(5_000_000)
    assert [e.sample_time_fine for e in h.of_type(SampleSent)] == [(1 << 32) - 3, 22, 47]


def test_packet_counter_wraps_and_can_jump() -> None:
    h = configured(FLIGHT)
    h.dev.jump_packet_counter(0xFFFE)
    h.advance(7_500_000)
    h.dev.jump_packet_counter(-5)
    h.advance(10_000_000)
    assert [e.packet_counter for e in h.of_type(SampleSent)] == [0xFFFE, 0xFFFF, 0, 1, 0xFFFD]


def test_mixed_rates_share_one_message_grid() -> None:
    h = configured([(0x1020, 0xFFFF), (0x2030, 100), (0x4020, 200)])
    assert h.dev.output_period_ns == 5_000_000
    frames = h.advance(20_000_000)
    assert [sorted(packets(f)) for f in frames] == [
        [0x1020, 0x2030, 0x4020], [0x1020, 0x4020], [0x1020, 0x2030, 0x4020], [0x1020, 0x4020],
        [0x1020, 0x2030, 0x4020]]


# -- frames ---------------------------------------------------------------------------------------

ROLL, PITCH, YAW = 10.0, -5.0, 30.0


def moving(entries: list[tuple[int, int]]) -> Frame:
    h = configured(entries)
    q = euler_deg_to_quat(ROLL, PITCH, YAW)
    f_S = rotate_inv(q, (0.0, 0.0, -G))  # at rest: specific force is minus gravity
    h.dev.set_motion(q, (0.1, -0.2, 0.3), f_S)
    (frame,) = h.advance(0)
    return frame


def test_ned_bits_give_the_inputs_as_given() -> None:
    f = moving(FLIGHT)
    q = euler_deg_to_quat(ROLL, PITCH, YAW)
    assert values(f, 0x2034) == pytest.approx((ROLL, PITCH, YAW), abs=1e-4)
    assert values(f, 0x8024) == pytest.approx((0.1, -0.2, 0.3), abs=1e-7)
    assert values(f, 0x4024) == pytest.approx(rotate_inv(q, (0.0, 0.0, -G)), abs=1e-5)
    assert int.from_bytes(packets(f)[0xE020], "big") == StatusFlag.SELFTEST_OK | StatusFlag.ORIENTATION_VALID


def test_enu_bits_rotate_the_reference_and_use_a_z_up_sensor_frame() -> None:
    f = moving([(0x2030, 400), (0x8020, 400), (0x4020, 400), (0x2010, 400)])
    assert values(f, 0x2030) == pytest.approx((ROLL, -PITCH, 90.0 - YAW), abs=1e-4)
    assert values(f, 0x8020) == pytest.approx((0.1, 0.2, -0.3), abs=1e-7)
    q_enu = values(f, 0x2010)
    assert q_enu == pytest.approx(euler_deg_to_quat(ROLL, -PITCH, 90.0 - YAW), abs=1e-6)


def test_nwu_bits() -> None:
    f = moving([(0x2038, 400), (0x4028, 400)])
    assert values(f, 0x2038) == pytest.approx((ROLL, -PITCH, -YAW), abs=1e-4)
    q = euler_deg_to_quat(ROLL, PITCH, YAW)
    fx, fy, fz = rotate_inv(q, (0.0, 0.0, -G))
    assert values(f, 0x4028) == pytest.approx((fx, -fy, -fz), abs=1e-5)


def test_level_north_facing_at_rest_reads_like_the_golden_mti300() -> None:
    h = configured([(0x2010, 400), (0x4020, 400), (0x4030, 400), (0xC024, 100), (0x4010, 400), (0x8030, 400)])
    (f,) = h.advance(0)
    assert values(f, 0x4020) == pytest.approx((0.0, 0.0, G), abs=1e-5)  # ENU default: +g up (golden: 9.82)
    assert values(f, 0x4030) == pytest.approx((0.0, 0.0, 0.0), abs=1e-5)  # free acceleration
    assert values(f, 0xC024) == pytest.approx((0.5, 0.0, 0.866), abs=1e-6)  # mag field, NED bits
    assert values(f, 0x4010) == pytest.approx((0.0, 0.0, G * 0.0025), abs=1e-7)  # DeltaV over 2.5 ms
    assert values(f, 0x8030) == pytest.approx((1.0, 0.0, 0.0, 0.0))
    half = math.sqrt(0.5)
    assert values(f, 0x2010) == pytest.approx((half, 0.0, 0.0, half), abs=1e-7)  # yaw 90 deg in ENU


def test_rotation_matrix_is_column_major() -> None:
    f = moving([(0x2024, 400)])
    r = quat_to_matrix(euler_deg_to_quat(ROLL, PITCH, YAW))
    assert values(f, 0x2024) == pytest.approx([r[row][col] for col in range(3) for row in range(3)], abs=1e-6)


@pytest.mark.parametrize("precision", [0x0, 0x1, 0x2, 0x3])
def test_euler_precisions(precision: int) -> None:
    xdi = 0x2034 | precision
    f = moving([(xdi, 400)])
    size = {0: 12, 1: 12, 2: 18, 3: 24}[precision]
    assert len(packets(f)[xdi]) == size
    assert values(f, xdi) == pytest.approx((ROLL, PITCH, YAW), abs=1e-4)


def test_saturation_sets_clip_bits_and_clears_orientation_valid() -> None:
    h = configured(FLIGHT)
    h.dev.set_motion((1.0, 0.0, 0.0, 0.0), (0.0, -20.0, 0.0), (0.0, 0.0, -300.0))
    (f,) = h.advance(0)
    status = int.from_bytes(packets(f)[0xE020], "big")
    assert status == (StatusFlag.SELFTEST_OK | StatusFlag.CLIP_GYR_Y | StatusFlag.CLIP_ACC_Z
                      | StatusFlag.CLIPPING_DETECTED)
    assert values(f, 0x8024)[1] == pytest.approx(-math.radians(450.0))
    assert values(f, 0x4024)[2] == pytest.approx(-200.0)


@pytest.mark.parametrize("settings_,expected_euler", [
    (0x0000_0005, (ROLL, -PITCH, -YAW)),  # NWU: the legacy default frame
    (0x8000_0005, (ROLL, PITCH, YAW)),  # bit 31: NED
])
def test_legacy_frames(settings_: int, expected_euler: tuple[float, ...]) -> None:
    h = Host.make(exact_params(identity=Identity.LEGACY))
    h.ask(MID.GOTO_CONFIG)
    h.ask(MID.SET_OUTPUT_MODE, struct.pack(">H", LegacyMode.CALIBRATED | LegacyMode.ORIENTATION))
    h.ask(MID.SET_OUTPUT_SETTINGS, struct.pack(">I", settings_))
    h.ask(MID.GOTO_MEASUREMENT)
    h.dev.set_motion(euler_deg_to_quat(ROLL, PITCH, YAW), (0.1, -0.2, 0.3), (1.0, 2.0, -9.0))
    (f,) = h.advance(0)
    v = decode_values(f.payload[:48], Precision.FLOAT32)
    assert v[9:12] == pytest.approx(expected_euler, abs=1e-4)
    ned = settings_ >> 31
    assert v[0:3] == pytest.approx((1.0, 2.0, -9.0) if ned else (1.0, -2.0, 9.0))
    assert v[3:6] == pytest.approx((0.1, -0.2, 0.3) if ned else (0.1, 0.2, -0.3))
    assert f.payload[-2:] == b"\x00\x00"  # sample counter
    (sent,) = h.of_type(SampleSent)
    assert sent.euler_deg == pytest.approx(v[9:12], abs=1e-5) and sent.sample_time_fine is None
    assert sent.acc_mps2 == pytest.approx(v[0:3], abs=1e-6) and sent.nbytes == 5 + 50


# -- error model ----------------------------------------------------------------------------------

def test_error_model_is_seeded() -> None:
    out = {}
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        h = Host.make(XsensParams(), seed=seed)
        out[name] = h.advance(1_000_000_000)
    assert len(out["a"]) == 101
    assert out["a"] == out["b"]
    assert out["a"] != out["c"]


def test_error_model_noise_level_and_bias() -> None:
    p = XsensParams()
    h = Host(configured([(0x8024, 400)], p).dev)
    h.advance(4_997_500_000)
    rates = np.array([e.rate_radps for e in h.of_type(SampleSent)])
    assert rates.shape == (2000, 3)
    sigma = p.gyro_noise_radps_per_rthz * math.sqrt(400)
    detrended = rates - rates.mean(axis=0)
    assert np.std(detrended, axis=0) == pytest.approx([sigma] * 3, rel=0.1)
    # a turn-on bias of the configured size (not zero, not huge), plus a slow random walk
    bias = np.abs(rates.mean(axis=0))
    assert np.all(bias < 5 * p.gyro_bias_sigma_radps) and np.any(bias > 0.05 * p.gyro_bias_sigma_radps)


def test_power_cycle_draws_new_turn_on_errors() -> None:
    h = configured([(0x8024, 400)], XsensParams())
    h.advance(0)
    first = h.of_type(SampleSent)[-1].rate_radps
    h.dev.power_cycle(1_000_000)
    h.advance(1_000_000_000)  # no WakeUpAck: back to measurement after 500 ms
    later = h.of_type(SampleSent)[-1].rate_radps
    assert first is not None and later is not None
    assert np.linalg.norm(np.subtract(first, later)) > 1e-4
