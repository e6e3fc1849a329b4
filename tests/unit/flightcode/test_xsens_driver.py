"""XSENS driver: boot handshakes (mk4 and legacy) against a scripted MTi, and the sample stream."""

from __future__ import annotations

import io
import math

import pytest

from flightcode.drivers.base import DeviceError
from flightcode.drivers.xsens import ImuParams, XsensDriver
from flightcode.log import Logger
from tests.unit.flightcode.fakes import FakeSerial, FakeXsens, xbus

FAST = ImuParams(goto_config_attempts=3, reply_timeout_s=0.02)


def _driver(legacy: bool = False) -> tuple[XsensDriver, FakeXsens, FakeSerial, io.StringIO]:
    port = FakeSerial("imu")
    dev = FakeXsens(port, legacy=legacy)
    out = io.StringIO()
    params = ImuParams(identity="legacy" if legacy else "mk4", goto_config_attempts=3, reply_timeout_s=0.02)
    return XsensDriver(port, params, Logger(out)), dev, port, out


def test_mk4_bring_up_sends_the_documented_sequence() -> None:
    drv, dev, port, out = _driver()
    info = drv.bring_up()
    drv.start()
    assert dev.requests == [0x30, 0x00, 0x1C, 0x12, 0xC0, 0x10]
    assert port.written[0] == bytes.fromhex("FA FF 30 00 D1")  # GoToConfig
    assert port.written[1] == bytes.fromhex("FA FF 00 00 01")  # ReqDID
    assert port.written[4] == bytes.fromhex(
        "FA FF C0 18 10 20 FF FF 10 60 FF FF 20 34 01 90 80 24 01 90 40 24 01 90 E0 20 FF FF 80")
    assert port.written[5] == bytes.fromhex("FA FF 10 00 F1")  # GoToMeasurement
    assert info.device_id == 0x037003F8 and info.product_code == "MTi-100-2A8G4" and info.firmware == "1.8.2"
    assert "event=imu.identified device_id=037003F8" in out.getvalue()
    assert dev.measuring


def test_legacy_bring_up_uses_mode_settings_period() -> None:
    drv, dev, port, _ = _driver(legacy=True)
    drv.bring_up()
    drv.start()
    assert dev.requests == [0x30, 0x00, 0x1C, 0x12, 0xD0, 0xD2, 0x04, 0x10]
    assert port.written[4] == xbus(0xD0, bytes.fromhex("0006"))  # calibrated + orientation
    assert port.written[5] == xbus(0xD2, bytes.fromhex("80000005"))  # NED | Euler | sample counter
    assert port.written[6] == xbus(0x04, (288).to_bytes(2, "big"))  # 400 Hz = 115200 / 288


def test_goto_config_is_resent_while_the_device_streams() -> None:
    drv, dev, port, _ = _driver()
    # The device is measuring and ignores the first GoToConfig (as if it was lost on the line).
    port.feed(dev.sample(0, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)) * 3)
    lost = [True]
    original = port.on_write

    def lossy(data: bytes) -> None:
        if lost[0]:
            lost[0] = False
            return
        original(data)

    port.on_write = lossy
    drv.bring_up()
    assert [w for w in port.written if w == bytes.fromhex("FA FF 30 00 D1")] == [bytes.fromhex("FA FF 30 00 D1")] * 2


def test_silent_device_fails_boot_naming_the_imu() -> None:
    drv, dev, port, _ = _driver()
    dev.silent = True
    with pytest.raises(DeviceError) as err:
        drv.bring_up()
    assert err.value.device == "imu"
    assert "GOTO_CONFIG" in str(err.value) and "3 attempt" in str(err.value)


def test_mk4_configuration_refused_points_at_identity() -> None:
    drv, dev, _, out = _driver()
    dev.refuse.add(0xC0)  # a legacy device answers Error 0x04
    with pytest.raises(DeviceError, match="imu.identity"):
        drv.bring_up()
    assert "event=imu.error_reply request=set_output_configuration code=4" in out.getvalue()


def test_configuration_ack_must_echo_the_request() -> None:
    drv, dev, port, _ = _driver()
    original = port.on_write

    def wrong_ack(data: bytes) -> None:
        if data[2] == 0xC0:
            port.feed(xbus(0xC1, bytes.fromhex("10 20 FF FF 20 34 00 64")))
        else:
            original(data)

    port.on_write = wrong_ack
    with pytest.raises(DeviceError, match="applied"):
        drv.bring_up()


def _started(legacy: bool = False) -> tuple[XsensDriver, FakeXsens, FakeSerial]:
    drv, dev, port, _ = _driver(legacy)
    drv.bring_up()
    drv.start()
    return drv, dev, port


def test_samples_carry_sensor_time_and_si_units() -> None:
    drv, dev, port = _started()
    port.feed(dev.sample(0, (10.0, -5.0, 90.0), (0.1, 0.2, 0.3), (0.0, 0.0, -9.81)))
    s0 = drv.read_sample(0.01)
    port.feed(dev.sample(2_500_000, (10.0, -5.0, 90.0), (0.1, 0.2, 0.3), (0.0, 0.0, -9.81)))
    s1 = drv.read_sample(0.01)
    assert s0 is not None and s1 is not None
    assert s0.t_ns == 0 and s1.t_ns == 2_500_000
    assert s0.euler_rad == pytest.approx((math.radians(10), math.radians(-5), math.radians(90)))
    assert s0.omega_B_radps == pytest.approx((0.1, 0.2, 0.3))
    assert s0.f_B_mps2 == pytest.approx((0.0, 0.0, -9.81))
    assert s0.status == 3 and s1.counter == s0.counter + 1


def test_newest_sample_wins_and_skips_are_counted() -> None:
    drv, dev, port = _started()
    for k in range(3):
        port.feed(dev.sample(k * 2_500_000, (float(k), 0, 0), (0, 0, 0), (0, 0, -9.8)))
    s = drv.read_sample(0.01)
    assert s is not None and s.skipped == 2 and s.euler_rad[0] == pytest.approx(math.radians(2))
    assert drv.counters["skipped_samples"] == 2


def test_counter_gaps_are_counted() -> None:
    drv, dev, port = _started()
    port.feed(dev.sample(0, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)))
    assert drv.read_sample(0.01) is not None
    dev.counter += 4  # four samples lost on the line
    port.feed(dev.sample(12_500_000, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)))
    s = drv.read_sample(0.01)
    assert s is not None and s.t_ns == 12_500_000
    assert drv.counters["gap_samples"] == 4 and drv.counters["gaps"] == 1


def test_timeout_returns_none() -> None:
    drv, _, _ = _started()
    assert drv.read_sample(0.0) is None


def test_babbling_device_still_trips_the_watchdog() -> None:
    drv, _, port = _started()
    port.on_starve = lambda: port.feed(b"\x55" * 200)  # garbage forever, never a frame
    assert drv.read_sample(0.02) is None
    assert drv.parser.counters["garbage_bytes"] > 0


def test_garbage_and_partial_frames_in_the_stream() -> None:
    drv, dev, port = _started()
    frame = dev.sample(0, (1, 2, 3), (0, 0, 0), (0, 0, -9.8))
    corrupted = bytearray(dev.sample(2_500_000, (9, 9, 9), (0, 0, 0), (0, 0, -9.8)))
    corrupted[20] ^= 0xFF
    good = dev.sample(5_000_000, (4, 5, 6), (0, 0, 0), (0, 0, -9.8))
    port.feed(b"\x00\xfa\x55" + frame[:30])
    assert drv.read_sample(0.0) is None  # half a frame: not a sample yet
    port.feed(frame[30:] + bytes(corrupted) + b"\xfa\xff\x36" + good)
    s = drv.read_sample(0.0)
    assert s is not None and s.euler_rad[0] == pytest.approx(math.radians(4))
    assert drv.parser.counters["checksum_errors"] >= 1 and drv.parser.counters["garbage_bytes"] >= 3


def test_sample_time_fine_wraps() -> None:
    drv, dev, port = _started()
    # SampleTimeFine near 2^32: the fake stamps t/100us + 1000, so start just below the wrap.
    t0 = (0xFFFFFFFF - 1000 - 1) * 100_000
    port.feed(dev.sample(t0, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)))
    assert drv.read_sample(0.0).t_ns == 0  # type: ignore[union-attr]
    port.feed(dev.sample(t0 + 2_500_000, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)))
    assert drv.read_sample(0.0).t_ns == 2_500_000  # type: ignore[union-attr]


def test_legacy_stream_time_from_the_sample_counter() -> None:
    drv, dev, port = _started(legacy=True)
    samples = []
    for k in range(2):
        port.feed(dev.sample(k * 2_500_000, (1.5, -2.25, 90.0), (0.1, 0.2, 0.3), (0.0, 0.0, -9.81)))
        samples.append(drv.read_sample(0.0))
    s0, s1 = samples
    assert s0 is not None and s1 is not None
    assert (s0.t_ns, s1.t_ns) == (0, 2_500_000)
    assert s1.euler_rad == pytest.approx((math.radians(1.5), math.radians(-2.25), math.radians(90)))
    assert s1.f_B_mps2 == pytest.approx((0.0, 0.0, -9.81))


def test_unexpected_message_in_measurement_is_counted() -> None:
    drv, dev, port = _started()
    port.feed(xbus(0x3E) + dev.sample(0, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)))  # a stray WakeUp
    assert drv.read_sample(0.01) is not None
    assert drv.counters["unexpected_messages"] == 1


def test_read_asks_for_a_whole_frame_at_once() -> None:
    # One read per sample when the device delivers frame by frame (docs/performance.md: pty round trips cost).
    drv, dev, port = _started()
    port.feed(dev.sample(0, (0, 0, 0), (0, 0, 0), (0, 0, -9.8)))
    reads = port.reads
    assert drv.read_sample(0.0) is not None
    assert port.reads - reads == 1


def _hover(dev, t_ns: int) -> bytes:
    return dev.sample(t_ns, (0, 0, 0), (0, 0, 0), (0, 0, -9.8))


def test_a_sample_whose_time_jumps_is_rejected() -> None:
    """A frame corrupted on the wire with a matching checksum: its SampleTimeFine is hours
    off (a high bit flipped). It is rejected and counted; the loop's clock goes on from the
    next good sample, one period per sample."""
    drv, dev, port = _started()
    port.feed(_hover(dev, 0))
    assert drv.read_sample(0.0).t_ns == 0  # type: ignore[union-attr]
    port.feed(_hover(dev, 2_500_000 + (1 << 30) * 100_000))  # SampleTimeFine + 2^30 ticks: 29.8 h later
    assert drv.read_sample(0.0) is None  # rejected, and nothing else arrived
    assert drv.counters["rejected_time_jumps"] == 1
    port.feed(_hover(dev, 5_000_000))
    s = drv.read_sample(0.0)
    assert s is not None and s.t_ns == 5_000_000
    assert drv.counters["gap_samples"] == 1  # the rejected sample is missing from the stream


def test_a_time_jump_backwards_is_rejected_too() -> None:
    drv, dev, port = _started()
    port.feed(_hover(dev, 10 * 2_500_000))
    drv.read_sample(0.0)
    port.feed(_hover(dev, 0))  # 25 ms back: unwrapped, 119 h forward
    assert drv.read_sample(0.0) is None
    port.feed(_hover(dev, 12 * 2_500_000))
    s = drv.read_sample(0.0)
    assert s is not None and s.t_ns == 2 * 2_500_000 and drv.counters["rejected_time_jumps"] == 1


def test_a_device_clock_that_stays_jumped_is_believed_again() -> None:
    """A device whose packet counter jumped: after a few rejections in a row its clock is
    believed again as it reads, so the IMU is not lost for good."""
    drv, dev, port = _started()
    port.feed(_hover(dev, 0))
    drv.read_sample(0.0)
    dev.counter += 1000
    got = []
    for k in range(1, 6):
        port.feed(_hover(dev, k * 2_500_000))
        got.append(drv.read_sample(0.0))
    assert got[0] is None and got[1] is None and got[2] is not None and got[3] is not None
    assert (got[2].t_ns, got[3].t_ns) == (3 * 2_500_000, 4 * 2_500_000)
    assert drv.counters["rejected_time_jumps"] == 2 and drv.counters["time_rebases"] == 1


def test_a_real_gap_keeps_its_time() -> None:
    """Samples lost on the line (counter and time advance together) are not a time jump."""
    drv, dev, port = _started()
    port.feed(_hover(dev, 0))
    drv.read_sample(0.0)
    dev.counter += 199  # 0.5 s of samples lost
    port.feed(_hover(dev, 200 * 2_500_000))
    s = drv.read_sample(0.0)
    assert s is not None and s.t_ns == 500_000_000 and drv.counters["rejected_time_jumps"] == 0


@pytest.mark.parametrize(("euler_deg", "gyr"), [
    ((1.0e19, 0.0, 0.0), (0.0, 0.0, 0.0)),   # a flipped exponent bit in roll
    ((0.0, 0.0, 0.0), (0.0, 40.0, 0.0)),     # 2290 deg/s: beyond any MTi's range
    ((16.0, 0.0, 0.0), (0.0, 0.0, 0.0)),     # 16 deg in 2.5 ms with the vehicle at rest
    ((0.0, 0.0, 0.0), (25.6, 0.0, 0.0)),     # 0.1 rad/s x 256: a jump no airframe makes
])
def test_a_sample_that_cannot_be_true_is_rejected(euler_deg, gyr) -> None:
    """A frame corrupted on the wire whose one-byte checksum still matches: the values are
    refused and counted, and the next good sample is taken. (A non-finite value is refused
    earlier, by the MTData2 decoder.)"""
    drv, dev, port = _started()
    port.feed(_hover(dev, 0))
    assert drv.read_sample(0.0) is not None
    port.feed(dev.sample(2_500_000, euler_deg, gyr, (0, 0, -9.8)))
    assert drv.read_sample(0.0) is None
    assert drv.counters["rejected_values"] == 1
    port.feed(_hover(dev, 5_000_000))
    s = drv.read_sample(0.0)
    assert s is not None and s.t_ns == 5_000_000


def test_a_manoeuvre_is_not_a_jump() -> None:
    """A 300 deg/s roll at 400 Hz moves 0.75 deg a sample: every sample is taken."""
    drv, dev, port = _started()
    for k in range(40):
        port.feed(dev.sample(k * 2_500_000, (0.75 * k, 0.0, 179.9 if k % 2 else -179.9),
                             (math.radians(300.0), 0.0, 0.0), (0, 0, -9.8)))
        assert drv.read_sample(0.0) is not None, k  # yaw crossing +-180 deg is no jump either
    assert drv.counters["rejected_values"] == 0


def test_a_jump_that_persists_is_believed_but_a_value_out_of_range_never() -> None:
    drv, dev, port = _started()
    port.feed(_hover(dev, 0))
    drv.read_sample(0.0)
    got = []
    for k in range(1, 5):  # the attitude really jumped (the device re-aligned): believed on the 3rd
        port.feed(dev.sample(k * 2_500_000, (20.0, 0.0, 0.0), (0, 0, 0), (0, 0, -9.8)))
        got.append(drv.read_sample(0.0))
    assert [g is not None for g in got] == [False, False, True, True]
    assert drv.counters["value_rebases"] == 1
    for k in range(5, 10):
        port.feed(dev.sample(k * 2_500_000, (20.0, 0.0, 0.0), (0, 50.0, 0), (0, 0, -9.8)))
        assert drv.read_sample(0.0) is None
    assert drv.counters["rejected_values"] == 2 + 5
