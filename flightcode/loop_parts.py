"""The flight loop's parts: its drivers (:class:`Devices`, built by :func:`make_devices`), the
controllers, estimator, modes and references it is built from, the state it carries from one
sample to the next, and the small services its steps share (port errors and rare anomalies
counted and logged sparsely, stick scaling, the ESC write, statistics, the barometer held
against the accelerometers' motion). The loop itself, the
order of its steps on each sample, is :mod:`flightcode.loop`.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from flightcode.config import FlightConfig
from flightcode.control.landing import HoverThrottle, LandingDescent
from flightcode.control.lqi_altitude import AltitudeModel, LqiAltitude
from flightcode.control.memory_attitude import MemoryAttitudeController, MemoryGains
from flightcode.control.mixer import Mixer
from flightcode.control.reference import Prefilter3
from flightcode.control.yaw_rate import YawRateController
from flightcode.drivers.analog import AccelRestOffset, AnalogChain, BaroReference
from flightcode.drivers.base import SerialLike
from flightcode.drivers.buspirate_spi import BusPirateSpi
from flightcode.drivers.maestro import MaestroEsc
from flightcode.drivers.mcp3204 import Mcp3204Reader
from flightcode.drivers.ppm_capture import CaptureRcInput
from flightcode.drivers.sbus import SbusRcInput
from flightcode.drivers.xbee import XbeeTelemetryLink
from flightcode.drivers.xsens import XsensDriver
from flightcode.estimation.altitude_kf import AltitudeKF
from flightcode.estimation.baro_motion import BaroMotionCheck
from flightcode.estimation.plausibility import AdcPlausibility
from flightcode.log import Logger
from flightcode.modes import Mode, ModeMachine
from flightcode.telemetry import ComputeWindow

_DEG = math.pi / 180.0
#: variance of the inertial vertical velocity the estimate is moved to when the barometer's
#: motion disagrees, (m/s)^2: (0.2 m/s)^2, twice the estimator's own at the window's start
BARO_MOTION_VZ_VAR = 0.04


@dataclass
class Devices:
    """The drivers the loop runs on (built by :func:`make_devices`)."""

    imu: XsensDriver
    adc_bridge: BusPirateSpi
    adc: Mcp3204Reader
    rc: CaptureRcInput | SbusRcInput
    esc: MaestroEsc
    telemetry: XbeeTelemetryLink | None


def make_devices(cfg: FlightConfig, ports: dict[str, SerialLike], log: Logger,
                 clock: Callable[[], float] = time.monotonic) -> Devices:
    """Drivers on already-open ports keyed ``imu``, ``adc``, ``rc``, ``esc`` (+ ``telemetry``).

    ``clock`` (monotonic seconds) times the ADC bridge's reply waits; tests pass a fake.
    """
    a = cfg.adc
    bridge = BusPirateSpi(ports["adc"], speed_hz=a.spi_speed_hz, entry_attempts=a.entry_attempts,
                          reply_timeout_s=a.reply_timeout_s, quiet_s=a.quiet_s,
                          resync_interval_ns=int(a.resync_interval_s * 1e9), log=log, clock=clock)
    adc = Mcp3204Reader(bridge, (a.baro_channel, *a.accel_channels))
    rc: CaptureRcInput | SbusRcInput
    if cfg.rc.frontend == "capture":
        rc = CaptureRcInput(ports["rc"], cfg.rc.capture)
    else:
        rc = SbusRcInput(ports["rc"], cfg.rc.sbus)
    telemetry = None
    if cfg.telemetry.enable:
        t = cfg.telemetry
        telemetry = XbeeTelemetryLink(ports["telemetry"], escaped=t.ap_mode == 2, dest16=t.dest16,
                                      request_status=t.request_status, max_out_waiting=t.max_out_waiting)
    return Devices(XsensDriver(ports["imu"], cfg.imu, log), bridge, adc, rc, MaestroEsc(ports["esc"], cfg.esc),
                   telemetry)


class LoopParts:
    """What :class:`flightcode.loop.FlightLoop` runs on ``devices`` with config ``cfg``.

    Args:
        perf_ns: the compute-time clock (``time.perf_counter_ns``); only measures, never paces.
    """

    def __init__(self, cfg: FlightConfig, devices: Devices, log: Logger,
                 perf_ns: Callable[[], int] = time.perf_counter_ns) -> None:
        self.cfg = cfg
        self.dev = devices
        self.log = log
        self._perf_ns = perf_ns
        self.counters: Counter[str] = Counter()
        T_s = cfg.T_s
        self.period_ns = round(1e9 / cfg.imu.rate_hz)
        att = cfg.attitude
        if att.law == "generalised":
            gains = MemoryGains.from_poles(T_s, att.omega1_radps, att.omega2_radps, att.k0_per_s, att.J_hat_kgm2,
                                           att.tau_ff_s, att.u_limit_Nm)
        else:
            gains = MemoryGains.paper_literal(T_s, att.k0_per_s, att.J_hat_kgm2, att.u_limit_Nm)
        self.roll_ctl = MemoryAttitudeController(gains)
        self.pitch_ctl = MemoryAttitudeController(gains)
        self.roll_pf = Prefilter3(att.prefilter_omega_radps, T_s)
        self.pitch_pf = Prefilter3(att.prefilter_omega_radps, T_s)
        self.yaw_ctl = YawRateController(cfg.yaw.kp_Nm_per_radps, cfg.yaw.ki_Nm_per_rad, cfg.yaw.u_limit_Nm, T_s)
        v, alt, kf = cfg.vehicle, cfg.altitude, cfg.kf
        self.model = AltitudeModel(v.m_kg, v.F_max_N, alt.T1_s)
        self.lqi = LqiAltitude(self.model, q_int=alt.q_int, q_z=alt.q_z, q_vz=alt.q_vz, q_az=alt.q_az, r=alt.r,
                               T_s=T_s)
        self.kf = AltitudeKF(self.model, T_s, kf.q_a, kf.q_d, kf.q_b, kf.r_baro_m2, kf.r_acc, kf.r_rest_vz,
                             kf.baro_gate_chi2, kf.baro_gate_timeout_s)
        self.plausible = AdcPlausibility(cfg.plausibility, cfg.T_s)
        pl = cfg.plausibility
        self.baro_motion = (BaroMotionCheck(pl.baro_motion_window_s, pl.baro_motion_block_s, pl.baro_motion_max_m)
                            if pl.baro_motion_window_s > 0 else None)
        self.mixer = Mixer(v.frame, v.arm_m, v.F_max_N / 4.0, v.kq_over_kt_m, v.mixer, self.model.d_h)
        self.analog = AnalogChain(cfg.adc.vref_V, cfg.adc.baro, cfg.adc.accel)
        self.baro_ref = BaroReference(int(cfg.adc.baro.zero_average_s * 1e9))
        self.accel_zero = AccelRestOffset()
        self.modes = ModeMachine(cfg.modes, alt.takeoff_alt_m)
        self.descent = LandingDescent(cfg.failsafe.descend_mps)
        self.hover = HoverThrottle(self.model.d_h)
        self.window = ComputeWindow()
        self._rc_loss_ns = int(cfg.failsafe.rc_loss_s * 1e9)
        self._rest_after_ns = int(cfg.kf.rest_after_s * 1e9)
        self._rest_anchored_ns: int | None = None  # the rest period whose start was handled
        self._tel_slot_ns = self.period_ns * cfg.telemetry.divider
        self._stats_ns = int(cfg.log.stats_period_s * 1e9)
        rc = cfg.rc
        self._ch = (rc.channel_roll - 1, rc.channel_pitch - 1, rc.channel_throttle - 1, rc.channel_yaw - 1)
        self._max_angle_rad = rc.max_angle_deg * _DEG
        self._max_yaw_rate_radps = rc.max_yaw_rate_dps * _DEG
        # State carried between samples.
        self._t_prev_ns: int | None = None
        self._u_applied = 0.0  # throttle deviation applied over the last sample (KF input)
        self._collective_applied = 0.0  # collective applied over the last sample (touchdown test)
        self._a_up_lp = 0.0  # XSENS vertical acceleration, low-passed (touchdown test), m/s^2
        self._z_ref_m = 0.0
        self._tel_seq = 0
        self._tel_last_slot = -1
        self._stats_next_ns = 0
        self._stats_max_ns = 0
        self._skipped_in_window = False
        self.last: dict[str, object] = {}

    # -- services of the steps ----------------------------------------------------------------
    def _write_esc(self, pulses_us: tuple[float, ...] | None) -> None:
        """One Maestro command (None = all motors to minimum); a port error is logged, not raised."""
        try:
            if pulses_us is None:
                self.dev.esc.write_minimum()
            else:
                self.dev.esc.write_pulses_us(pulses_us)
        except OSError as exc:
            self._port_error("esc", exc)

    def _port_error(self, device: str, exc: OSError) -> None:
        """Count a serial error; log it on the 1st, 2nd, 4th, 8th... occurrence (a pulled
        cable must not turn into 400 log lines a second)."""
        key = f"{device}_port_errors"
        self.counters[key] += 1
        n = self.counters[key]
        if n & (n - 1) == 0:
            self.log.error(f"{device}.port_error", count=n, error=str(exc))

    def _rare(self, key: str, event: str, **fields: object) -> None:
        """Count an in-flight anomaly in ``self.counters[key]``; log it (warning) on the 1st,
        2nd, 4th, 8th... occurrence, as the port errors are."""
        self.counters[key] += 1
        n = self.counters[key]
        if n & (n - 1) == 0:
            self.log.warning(event, count=n, **fields)

    def _log_transitions(self) -> None:
        for tr in self.modes.transitions:
            self.log.info("mode", old=tr.old, new=tr.new, cause=tr.event.value)
        self.modes.transitions.clear()

    def _sticks(self, channels: tuple[float, ...]) -> tuple[float, float, float, float, float, float]:
        """(roll_cmd rad, pitch_cmd rad, yaw_rate_cmd rad/s, z_ref m, throttle us, yaw us)."""
        rc = self.cfg.rc
        i_r, i_p, i_t, i_y = self._ch
        roll_us, pitch_us, thr_us, yaw_us = channels[i_r], channels[i_p], channels[i_t], channels[i_y]
        center, half = rc.center_us, rc.half_range_us

        def unit(pulse: float) -> float:
            x = (pulse - center) / half
            return 1.0 if x > 1.0 else -1.0 if x < -1.0 else x

        alt_range = self.cfg.altitude.alt_range_m
        z = alt_range * (thr_us - rc.throttle_low_us) / rc.throttle_range_us
        z = alt_range if z > alt_range else 0.0 if z < 0.0 else z
        return (unit(roll_us) * self._max_angle_rad, unit(pitch_us) * self._max_angle_rad,
                unit(yaw_us) * self._max_yaw_rate_radps, z, thr_us, yaw_us)

    def _check_baro_motion(self, dt_s: float, z_baro: float | None, a_up: float | None) -> float | None:
        """The barometer against the accelerometers' motion (flightcode/estimation/baro_motion.py):
        the reading, or None while its motion disagrees with the vehicle's. ``a_up``: this
        sample's vertical acceleration as the estimator takes it, m/s^2 (None: refused)."""
        check = self.baro_motion
        if check is None:
            return z_baro
        kf, modes = self.kf, self.modes
        if not modes.controllers_active:
            check.on_ground()
            return z_baro
        judging = kf.z_m >= self.cfg.kf.ground_effect_alt_m and not modes.ground_contact
        was_refusing = check.refusing
        if not check.add(dt_s, z_baro, a_up, kf.z_m, kf.vz_mps, judging):
            if was_refusing:
                self.log.info("baro.motion_agrees", z_hat_m=kf.z_m, z_baro_m=z_baro,
                              refused=self.counters["baro_motion_refused"])
            return z_baro
        target = check.take_reanchor()
        if target is not None:
            z_var_m2 = (check.max_m / 3.0) ** 2  # the inertial height is good to the check's tolerance
            self.log.warning("baro.motion_disagrees", z_hat_m=kf.z_m, z_inertial_m=target[0],
                             vz_inertial_mps=target[1], z_baro_m=z_baro)
            kf.move_to(target[0], target[1], z_var_m2, BARO_MOTION_VZ_VAR)
        if z_baro is not None:
            self.counters["baro_motion_refused"] += 1
        return None

    def _fix_references(self) -> None:
        """End of the boot averaging: altitude zero, accelerometer offsets, estimator start."""
        ref = self.baro_ref
        self.log.info("baro.reference", p_ref_Pa=ref.p_ref_Pa, samples=ref.samples)
        offset = self.accel_zero.fix()
        if self.accel_zero.rejected:
            self.log.warning("accel.offset_rejected", limit_mps2=self.accel_zero.limit_mps2)
        else:
            self.log.info("accel.offset", x_mps2=offset[0], y_mps2=offset[1], z_mps2=offset[2])
        # z = 0 is known to the accuracy of the average, not of one reading
        self.kf.reset(0.0, z_var_m2=self.cfg.kf.r_baro_m2 / max(1, ref.samples))

    def _rc_errors(self) -> int:
        c = self.dev.rc.counters
        return sum(c[k] for k in ("crc_errors", "bad_flags", "sequence_gaps", "overruns", "missing_edges",
                                  "bad_pulses", "garbage_bytes", "failsafe_frames"))

    def _log_stats(self, mode: Mode, z_hat: float) -> None:
        d = self.dev
        self.log.info("stats", mode=mode, z_hat_m=z_hat, compute_max_us=self._stats_max_ns / 1000.0,
                      imu_gaps=d.imu.counters["gap_samples"], imu_skipped=d.imu.counters["skipped_samples"],
                      adc_failed=d.adc.counters["failed_reads"], adc_resyncs=d.adc_bridge.counters["resyncs"],
                      adc_implausible=self.plausible.refused, baro_rejected=self.kf.counters["baro_rejected"],
                      baro_motion_worst_m=round(self.baro_motion.take_worst(), 3) if self.baro_motion else "off",
                      baro_motion_refused=self.counters["baro_motion_refused"],
                      accel_offset_worst_mps2=round(self.plausible.take_offset_worst(), 3),
                      hover_collective=self.hover.collective,
                      rc_errors=self._rc_errors(),
                      telemetry_sent=d.telemetry.counters["sent"] if d.telemetry is not None else 0)
        self._stats_max_ns = 0
