"""Sensor faults seen on the wire: the XSENS MTData2 values the flight code decodes, the MCP3204
codes it reads through the Bus Pirate, each compared with a fault-free twin of the same seed
(the devices draw the same noise in both, so the difference is the fault)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from emulators.analog.inverse import f_B_mps2_from_codes, pressure_Pa_from_code
from emulators.mcp3204.defs import fig61_decode, fig61_request
from hil.faults import load_faults
from hil.config.rig import Rig
from tests.unit.faults.harness import Bench, adc_enter_spi, adc_series, imu_samples

G = 9.80665
OMEGA_B = (1.0, -0.5, 0.3)  # rad/s, a tumble so rates and attitude move


def tumble(b: Bench) -> None:
    b.devices.plant.set_kinematic_state((0.0, 0.0, -50.0), omega_B_radps=OMEGA_B)


async def imu_twins(rig: Rig, raw: list[dict[str, Any]], until_s: float = 0.3, moving: bool = False) -> tuple[Bench, Bench]:
    faulty = Bench(rig, load_faults(raw, rig, source="test"))
    clean = Bench(rig)
    for b in (faulty, clean):
        if moving:
            tumble(b)
        await b.run_to(until_s)
    return faulty, clean


def series(b: Bench, key: str, t0_s: float = 0.0, t1_s: float = 1e9) -> np.ndarray:
    """One MTData2 field per sample (rows at 400 Hz from t = 0)."""
    arr = np.array([s[key] for s in imu_samples(b.received("imu"))], dtype=float)
    return arr[round(t0_s * 400) : round(t1_s * 400)] if t1_s < 1e9 else arr[round(t0_s * 400) :]


def window(raw: dict[str, Any]) -> dict[str, Any]:
    return {"t_s": 0.1, "duration_s": 0.1, **raw}


# -- IMU ---------------------------------------------------------------------------------------------
async def test_imu_bias_shifts_rates_and_acceleration_by_the_bias(frig: Rig) -> None:
    raw = [window({"kind": "imu.bias", "gyro_bias_S_radps": [0.02, -0.01, 0.0], "acc_bias_S_mps2": [0.0, 0.0, 0.5]})]
    b, c = await imu_twins(frig, raw)
    d_rate = series(b, "rate_radps", 0.1, 0.2) - series(c, "rate_radps", 0.1, 0.2)
    d_acc = series(b, "acc_mps2", 0.1, 0.2) - series(c, "acc_mps2", 0.1, 0.2)
    assert np.allclose(d_rate, [0.02, -0.01, 0.0], atol=1e-6) and np.allclose(d_acc, [0.0, 0.0, 0.5], atol=1e-5)
    assert np.array_equal(series(b, "euler_deg", 0.1, 0.2), series(c, "euler_deg", 0.1, 0.2))
    assert b.received("imu", 0.2) == c.received("imu", 0.2)  # ended on time, nothing left behind
    assert b.devices.imu_motion is None


async def test_imu_drift_grows_linearly_from_the_start(frig: Rig) -> None:
    raw = [window({"kind": "imu.drift", "gyro_drift_S_radps_per_s": [0.0, 0.0, 0.5]})]
    b, c = await imu_twins(frig, raw)
    dz = (series(b, "rate_radps", 0.1, 0.2) - series(c, "rate_radps", 0.1, 0.2))[:, 2]
    t = np.arange(40) / 400.0
    assert np.allclose(dz, 0.5 * t, atol=1e-6)
    assert b.received("imu", 0.2) == c.received("imu", 0.2)


async def test_imu_scale_multiplies_the_true_motion(frig: Rig) -> None:
    raw = [window({"kind": "imu.scale", "gyro_scale": [1.1, 1.0, 0.9], "acc_scale": 1.5})]
    b, c = await imu_twins(frig, raw, moving=True)
    truth = b.truth[40:80]
    w = np.array([s.omega_S_radps for s in truth])
    f = np.array([s.f_S_mps2 for s in truth])
    d_rate = series(b, "rate_radps", 0.1, 0.2) - series(c, "rate_radps", 0.1, 0.2)
    d_acc = series(b, "acc_mps2", 0.1, 0.2) - series(c, "acc_mps2", 0.1, 0.2)
    assert np.allclose(d_rate, w * [0.1, 0.0, -0.1], atol=1e-5) and np.abs(d_rate[:, 0]).min() > 0.05
    assert np.allclose(d_acc, 0.5 * f, atol=1e-5)
    assert b.received("imu", 0.2) == c.received("imu", 0.2)


async def test_imu_noise_adds_the_missing_variance(frig: Rig) -> None:
    raw = [{"kind": "imu.noise", "t_s": 0.1, "duration_s": 0.4, "noise_factor": 10.0, "signals": "gyro"}]
    b, c = await imu_twins(frig, raw, until_s=0.6)
    d_rate = series(b, "rate_radps", 0.1, 0.5) - series(c, "rate_radps", 0.1, 0.5)
    sigma = frig.imu.gyro_noise_radps_per_rthz * math.sqrt(400) * math.sqrt(10.0**2 - 1)
    assert abs(d_rate.std() / sigma - 1) < 0.1
    assert np.array_equal(series(b, "acc_mps2"), series(c, "acc_mps2"))
    assert b.received("imu", 0.5) == c.received("imu", 0.5)


async def test_imu_freeze_holds_attitude_and_rates_while_the_vehicle_tumbles(frig: Rig) -> None:
    b, c = await imu_twins(frig, [window({"kind": "imu.freeze"})], moving=True)
    held, moving = series(b, "euler_deg", 0.1, 0.2), series(c, "euler_deg", 0.1, 0.2)
    assert np.ptp(moving[:, 0]) > 4.0  # ~1 rad/s of roll over 0.1 s
    assert np.ptp(held, axis=0).max() < 0.5  # only the device's orientation noise
    assert np.allclose(held[0], moving[0], atol=0.5)  # the values of t_s
    rates = series(b, "rate_radps", 0.1, 0.2)
    assert np.allclose(rates, rates[0], atol=0.02)
    assert b.received("imu", 0.2) == c.received("imu", 0.2)


async def test_imu_saturation_clips_at_the_smaller_range(frig: Rig) -> None:
    raw = [window({"kind": "imu.saturation", "gyro_range_radps": 0.4})]
    b, c = await imu_twins(frig, raw, moving=True)
    clipped, free = series(b, "rate_radps", 0.1, 0.2), series(c, "rate_radps", 0.1, 0.2)
    assert np.abs(free[:, 0]).min() > 0.9
    assert np.allclose(clipped[:, 0], free[:, 0] - (np.sign(free[:, 0]) * (np.abs(free[:, 0]) - 0.4)), atol=0.03)
    assert np.array_equal(clipped[:, 2], free[:, 2])  # |0.3| < 0.4: untouched
    assert b.received("imu", 0.2) == c.received("imu", 0.2)


# -- analog chain through the ADC ------------------------------------------------------------------------
async def adc_twins(rig: Rig, raw: list[dict[str, Any]], n_ticks: int, channels: tuple[int, ...] = (0, 1, 2, 3),
                    lift_m: float | None = None) -> tuple[np.ndarray, np.ndarray, Bench]:
    out = []
    faulty = Bench(rig, load_faults(raw, rig, source="test"))
    for b in (faulty, Bench(rig)):
        if lift_m is not None:
            b.devices.plant.set_kinematic_state((0.0, 0.0, -lift_m))
        await adc_enter_spi(b)
        out.append(np.array(await adc_series(b, channels, n_ticks)))
    return out[0], out[1], faulty


def pressures(rig: Rig, codes: np.ndarray) -> np.ndarray:
    return np.array([pressure_Pa_from_code(int(c), rig.analog) for c in codes])


def rows(t0_s: float, t1_s: float) -> slice:
    return slice(round(t0_s * 400), round(t1_s * 400))


async def test_baro_bias_drift_and_scale_move_the_pressure_reading(rig: Rig) -> None:
    raw = [
        {"kind": "baro.bias", "t_s": 0.05, "duration_s": 0.05, "bias_Pa": 100.0},
        {"kind": "baro.drift", "t_s": 0.15, "duration_s": 0.1, "drift_Pa_per_s": 1000.0},
        {"kind": "baro.scale", "t_s": 0.3, "duration_s": 0.05, "scale": 0.999},
    ]
    f, c, b = await adc_twins(rig, raw, 160, channels=(0,))
    dp = pressures(rig, f[:, 0]) - pressures(rig, c[:, 0])
    lsb = 1.8  # Pa per code at gain 16
    assert abs(np.median(dp[rows(0.06, 0.1)]) - 100.0) < lsb
    assert abs(dp[rows(0.2, 0.25)].mean() - 1000.0 * 0.075) < 2 * lsb  # mid-window of the ramp
    assert dp[rows(0.24, 0.25)].mean() > dp[rows(0.16, 0.17)].mean() + 60
    assert abs(np.median(dp[rows(0.31, 0.35)]) + 0.001 * 101_325) < 10 * lsb
    assert np.abs(dp[rows(0.0, 0.05)]).max() == 0 and np.abs(dp[rows(0.36, 0.4)]).max() <= lsb
    assert b.devices.analog.baro_fault.bias_Pa == 0.0 and b.devices.analog.baro_fault.scale == 1.0


async def test_baro_noise_multiplies_the_sensor_noise(rig: Rig) -> None:
    f, c, _ = await adc_twins(rig, [{"kind": "baro.noise", "t_s": 0.0, "duration_s": 0.5, "noise_factor": 4.0}], 200,
                              channels=(0,))
    ratio = f[:, 0].std() / c[:, 0].std()
    assert 3.0 < ratio < 4.5


async def test_baro_freeze_holds_the_reading_through_a_pressure_change(rig: Rig) -> None:
    # a 300 Pa bias arrives during the freeze (twin: the bias alone) - the frozen output ignores it
    bias = {"kind": "baro.bias", "t_s": 0.1, "duration_s": 0.1, "bias_Pa": 300.0}
    faulty = Bench(rig, load_faults([{"kind": "baro.freeze", "t_s": 0.05, "duration_s": 0.1}, bias], rig, source="t"))
    twin = Bench(rig, load_faults([bias], rig, source="t"))
    codes = []
    for b in (faulty, twin):
        await adc_enter_spi(b)
        codes.append(np.array(await adc_series(b, (0,), 100))[:, 0])
    f, t = codes
    assert np.ptp(f[rows(0.06, 0.15)]) <= 2 and np.ptp(t[rows(0.06, 0.1)]) > 5  # held vs. noisy
    assert t[rows(0.11, 0.15)].mean() - f[rows(0.11, 0.15)].mean() > 100  # the bias does not show
    assert abs(np.median(f[rows(0.16, 0.2)]) - np.median(t[rows(0.16, 0.2)])) <= 1  # released


async def test_baro_port_blocked_hides_a_climb_but_not_the_sensor_noise(rig: Rig) -> None:
    # Both benches climb 10 m at 0.1 s (about 118 Pa less at the port); the blocked port
    # (0.05-0.2 s) keeps the trapped pressure, with the live sensor's noise, unlike baro.freeze.
    faulty = Bench(rig, load_faults([{"kind": "baro.port_blocked", "t_s": 0.05, "duration_s": 0.15}], rig, source="t"))
    twin = Bench(rig)
    codes = []
    for b in (faulty, twin):
        await adc_enter_spi(b)
        first = await adc_series(b, (0,), 40)
        b.devices.plant.set_kinematic_state((0.0, 0.0, -10.0))
        codes.append(np.array(first + await adc_series(b, (0,), 80))[:, 0])
    f, t = (pressures(rig, c) for c in codes)
    lsb = 1.8  # Pa per code at gain 16
    assert np.median(t[rows(0.0, 0.1)]) - np.median(t[rows(0.12, 0.2)]) > 100  # the climb, seen
    assert abs(np.median(f[rows(0.12, 0.2)]) - np.median(f[rows(0.0, 0.1)])) < 2 * lsb  # hidden
    assert np.std(f[rows(0.1, 0.2)]) > 0.5 * np.std(t[rows(0.11, 0.2)]) > lsb  # not a flat line
    assert abs(np.median(f[rows(0.22, 0.3)]) - np.median(t[rows(0.22, 0.3)])) < 2 * lsb  # released


async def test_baro_ground_effect_only_near_the_ground(rig: Rig) -> None:
    raw = [{"kind": "baro.ground_effect", "t_s": 0.0, "error_at_ground_Pa": 60.0, "decay_height_m": 0.5}]
    f, c, _ = await adc_twins(rig, raw, 40, channels=(0,))
    assert abs(np.median(pressures(rig, f[10:, 0]) - pressures(rig, c[10:, 0])) - 60.0) < 2.0
    f, c, _ = await adc_twins(rig, raw, 40, channels=(0,), lift_m=5.0)
    assert np.abs(pressures(rig, f[:, 0]) - pressures(rig, c[:, 0])).max() < 2.0


def ideal_accel(rig: Rig) -> Rig:
    """The rig with a nominal ADXL335 (no unit sensitivity/offset/cross-axis spread), so the
    nominal inverse in emulators/analog/inverse.py is exact."""
    accel = dataclasses.replace(
        rig.analog.accel, sensitivity_tolerance=0.0, zero_g_tolerance_V_at_3V=(0.0, 0.0, 0.0),
        zero_g_drift_mg_per_C=(0.0, 0.0, 0.0), cross_axis_fraction=0.0,
    )
    return dataclasses.replace(rig, analog=dataclasses.replace(rig.analog, accel=accel))


async def test_accel_bias_drift_scale(rig: Rig) -> None:
    rig = ideal_accel(rig)
    raw = [
        {"kind": "accel.bias", "t_s": 0.05, "duration_s": 0.05, "bias_B_mps2": [1.0, 0.0, 0.0]},
        {"kind": "accel.drift", "t_s": 0.15, "duration_s": 0.1, "drift_B_mps2_per_s": [0.0, 20.0, 0.0]},
        {"kind": "accel.scale", "t_s": 0.3, "duration_s": 0.05, "scale": 1.2},
    ]
    f, c, _ = await adc_twins(rig, raw, 160, channels=(1, 2, 3))

    def accel(codes: np.ndarray) -> np.ndarray:
        return np.array([f_B_mps2_from_codes(tuple(int(x) for x in r), rig.analog) for r in codes])

    d = accel(f) - accel(c)
    lsb = 0.04  # m/s^2 per code, roughly
    assert np.allclose(np.median(d[rows(0.07, 0.1)], axis=0), [1.0, 0.0, 0.0], atol=2 * lsb)
    assert abs(d[rows(0.24, 0.25), 1].mean() - 20.0 * 0.09) < 0.2
    assert np.allclose(np.median(d[rows(0.32, 0.35)], axis=0), [0.0, 0.0, -0.2 * G], atol=3 * lsb)
    assert np.abs(d[rows(0.0, 0.05)]).max() == 0 and np.abs(d[rows(0.38, 0.4)]).max() <= 2 * lsb


async def test_accel_noise_freeze_and_saturation(rig: Rig) -> None:
    bias = {"kind": "accel.bias", "t_s": 0.1, "duration_s": 0.05, "bias_B_mps2": [2.0, 0.0, 0.0]}
    raw = [
        {"kind": "accel.noise", "t_s": 0.0, "duration_s": 0.05, "noise_factor": 30.0},
        {"kind": "accel.freeze", "t_s": 0.075, "duration_s": 0.1},
        bias,
        {"kind": "accel.saturation", "t_s": 0.2, "duration_s": 0.1},
    ]
    faulty = Bench(rig, load_faults(raw, rig, source="t"))
    twin = Bench(rig, load_faults([bias], rig, source="t"))
    out = []
    for b in (faulty, twin):
        await adc_enter_spi(b)
        out.append(np.array(await adc_series(b, (1, 2, 3), 140)))
    f, t = out
    assert f[rows(0.0, 0.05), 0].std() > 5 * t[rows(0.0, 0.05), 0].std()  # noise x30
    assert np.ptp(f[rows(0.08, 0.175)], axis=0).max() <= 2  # frozen: the 2 m/s^2 bias never shows
    assert t[rows(0.11, 0.15), 0].mean() - t[rows(0.05, 0.1), 0].mean() > 40
    pinned = f[rows(0.24, 0.3)]
    assert set(np.unique(np.round(pinned / 100))) <= {1.0, 25.0}  # 0.1 V (82) or Vs - 0.2 V (2539)
    assert abs(pinned[:, 2].mean() - 2539) < 3  # Z reads +1 g: the high rail
    assert np.abs(f[rows(0.33, 0.35)] - t[rows(0.33, 0.35)]).max() <= 3  # all released


async def test_adc_channel_stuck_and_open(rig: Rig) -> None:
    raw = [
        {"kind": "adc.channel_stuck", "t_s": 0.05, "duration_s": 0.05, "channel": 2, "stuck_V": 2.0},
        {"kind": "adc.channel_open", "t_s": 0.05, "duration_s": 0.2, "channel": 1},
    ]
    f, c, _b = await adc_twins(rig, raw, 140)
    assert set(f[rows(0.05, 0.1), 2]) <= {1637, 1638, 1639} and abs(c[rows(0.05, 0.1), 2].mean() - 1638) > 100
    assert np.abs(f[rows(0.11, 0.15), 2] - c[rows(0.11, 0.15), 2]).max() <= 2  # released
    cut = f[rows(0.05, 0.25), 1]
    assert abs(int(cut[0]) - int(c[20, 1])) < 20 and cut[-10:].mean() < 40  # towards 0 V (tau 50 ms)
    assert np.all(np.diff(cut[::10].astype(float)) < 5)
    # (the floating input draws noise from the front-end's generator: the twins' noise differs now)
    assert np.abs(f[rows(0.3, 0.35), 1] - c[rows(0.3, 0.35), 1]).max() <= 4


async def test_adc_vref_step_and_drift(rig: Rig) -> None:
    raw = [
        {"kind": "adc.vref_drift", "t_s": 0.05, "duration_s": 0.05, "step_V": -0.5},
        {"kind": "adc.vref_drift", "t_s": 0.15, "duration_s": 0.1, "drift_V_per_s": -1.0},
    ]
    f, c, b = await adc_twins(rig, raw, 120)
    expect = np.round(c[rows(0.05, 0.1)] * 5.0 / 4.5)
    assert np.abs(f[rows(0.05, 0.1)] - expect).max() <= 2
    ramp = f[rows(0.15, 0.25), 1] / c[rows(0.15, 0.25), 1]
    vref = 5.0 - 1.0 * np.arange(40) / 400
    assert np.allclose(ramp, 5.0 / vref, atol=0.003)
    assert np.array_equal(f[rows(0.1, 0.15)], c[rows(0.1, 0.15)]) and np.array_equal(f[rows(0.25, 0.3)], c[rows(0.25, 0.3)])
    assert b.devices.mcp.vref_V == 5.0
    starts = [d["changed"]["vref_V"] for _, _, d in b.fault_events(" start")]
    assert starts == [4.5, 5.0]


async def _raw_replies(b: Bench, n_ticks: int) -> list[bytes]:
    """The MCP3204's 3 bytes of a Fig. 6-1 read of CH1 after each tick, as the Bus Pirate returns them."""
    client, out = b.ports["adc"].client, []
    for _ in range(n_ticks):
        await b.tick()
        client.read_now()
        await b.write("adc", b"\x02\x12" + fig61_request(1) + b"\x03")
        out.append(client.read_now()[2:5])
    return out


async def test_adc_dout_pulled_up_reads_the_hi_z_clocks_as_ones_and_keeps_the_code(rig: Rig) -> None:
    raw = [{"kind": "adc.dout_pulled_up", "t_s": 0.05, "duration_s": 0.05}]
    faulty, clean = Bench(rig, load_faults(raw, rig, source="test")), Bench(rig)
    replies = []
    for b in (faulty, clean):
        await adc_enter_spi(b)  # push-pull, pull-ups off: the Bus Pirate's own leave hi-Z at 0
        replies.append(await _raw_replies(b, 60))
    f, c = replies
    # Fig. 6-1 puts 13 clocks before B11: DOUT is hi-Z for 12, then the null bit (0)
    assert all(r[0] == 0xFF and r[1] & 0xF0 == 0xE0 for r in f[rows(0.05, 0.1)])
    assert all(r[0] == 0x00 and r[1] & 0xF0 == 0x00 for r in f[rows(0.0, 0.05)] + f[rows(0.1, 0.15)])
    assert all(r[0] == 0x00 and r[1] & 0xF0 == 0x00 for r in c)
    assert [fig61_decode(r) for r in f] == [fig61_decode(r) for r in c]  # the conversion is the same
    assert not faulty.devices.mcp.dout_pulled_up
