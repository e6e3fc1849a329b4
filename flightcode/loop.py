"""The 400 Hz loop: one iteration per IMU sample, everything timed on sensor time.

Boot (:meth:`FlightLoop.boot`): XSENS to config state, identified and configured; Bus Pirate
into binary SPI mode; Maestro to minimum pulses; XSENS GoToMeasurement last, so the first
sample is the loop's first tick.

Each iteration (:meth:`FlightLoop.step`):

1. block on the next IMU sample (read timeout = the IMU-loss watchdog; a timeout sends the
   motors to minimum and puts the modes into FAILSAFE_IMU);
2. read the four ADC channels (one pipelined Bus Pirate write, one read); readings the
   sensors cannot produce are dropped (:mod:`flightcode.estimation.plausibility`);
3. take the RC input (non-blocking read of whatever arrived);
4. estimate altitude (KF predict with the throttle applied over the last sample, update with
   barometer altitude, gated against outliers, and tilt-compensated vertical acceleration);
5. modes (gestures, take-off, landing, failsafe); a landing (the throttle stick at or below
   the take-off threshold in flight, or the RC failsafe) is flown as a descent that does not
   stop at the estimated ground (:mod:`flightcode.control.landing`);
6. control: stick prefilters, memory attitude (roll, pitch), PI yaw rate, LQI altitude;
7. mix and write one Maestro Set Multiple Targets;
8. telemetry every ``telemetry.divider``-th sample slot of sensor time (50 Hz at 400 Hz).

Compute time is ``perf_counter_ns`` around the iteration minus the two blocking exchanges (IMU
wait, ADC transaction) and goes into telemetry. A device that misbehaves in flight (garbage,
silence, a serial error) is counted and logged; the loop keeps flying on what it has or fails
safe, it never stops.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from flightcode.config import FlightConfig
from flightcode.control.landing import ACCEL_LP_TAU_S, HoverThrottle, LandingDescent
from flightcode.control.lqi_altitude import AltitudeModel, LqiAltitude
from flightcode.control.memory_attitude import MemoryAttitudeController, MemoryGains
from flightcode.control.mixer import Mixer
from flightcode.control.reference import Prefilter3, RefState
from flightcode.control.yaw_rate import YawRateController
from flightcode.drivers.analog import (
    G0_MPS2,
    AccelRestOffset,
    AnalogChain,
    BaroReference,
)
from flightcode.drivers.base import SerialLike
from flightcode.drivers.buspirate_spi import BusPirateSpi
from flightcode.drivers.maestro import MaestroEsc
from flightcode.drivers.mcp3204 import Mcp3204Reader
from flightcode.drivers.ppm_capture import CaptureRcInput
from flightcode.drivers.sbus import SbusRcInput
from flightcode.drivers.xbee import XbeeTelemetryLink
from flightcode.drivers.xsens import ImuSample, XsensDriver
from flightcode.estimation.altitude_kf import AltitudeKF
from flightcode.estimation.plausibility import AdcPlausibility
from flightcode.log import Logger
from flightcode.modes import Mode, ModeMachine, MotorPolicy
from flightcode.telemetry import ComputeWindow, TelemetryFlags, TelemetryRecord, encode

_DEG = math.pi / 180.0


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


class FlightLoop:
    """The flight code's main loop on ``devices`` with config ``cfg``.

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
        self.plausible = AdcPlausibility(cfg.plausibility)
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

    # -- boot / shutdown ------------------------------------------------------------------
    def boot(self, before_measurement: Callable[[], object] | None = None) -> None:
        """Bring every device up (DeviceError names the one that does not answer).

        ``before_measurement`` runs once everything is configured and before XSENS
        GoToMeasurement: from GoToMeasurement on, a sample arrives every 2.5 ms, so slow
        one-off work (the garbage collector's full collection and freeze,
        flightcode/gc_policy.py: 12-19 ms) belongs here, not between the first samples.
        """
        d = self.dev
        info = d.imu.bring_up()
        d.adc_bridge.enter_spi()
        d.esc.write_minimum()
        self.log.info("esc.minimum", pulse_us=self.cfg.esc.min_us)
        if d.telemetry is not None:
            d.telemetry.drain()
        if before_measurement is not None:
            before_measurement()
        d.imu.start()
        self.log.info("boot.done", imu_device_id=f"{info.device_id:08X}", rc_frontend=self.cfg.rc.frontend,
                      attitude_law=self.cfg.attitude.law, accel_source=self.cfg.kf.accel_source)

    def shutdown(self) -> None:
        """Motors to minimum (called on SIGTERM/SIGINT and on any exit path)."""
        self._write_esc(None)
        self.log.info("shutdown", pulse_us=self.cfg.esc.min_us)

    def _write_esc(self, pulses_us: tuple[float, ...] | None) -> None:
        """One Maestro command (None = all motors to minimum); a port error is logged, not raised."""
        try:
            if pulses_us is None:
                self.dev.esc.write_minimum()
            else:
                self.dev.esc.write_pulses_us(pulses_us)
        except OSError as exc:
            self._port_error("esc", exc)

    # -- running ----------------------------------------------------------------------------
    def run(self, max_iterations: int | None = None, between: Callable[[], object] | None = None) -> None:
        """Iterate forever (or ``max_iterations`` IMU reads, samples and timeouts alike);
        ``between`` runs after each iteration, once its ESC command is written (the garbage
        collector's slot, flightcode/gc_policy.py)."""
        n = 0
        while max_iterations is None or n < max_iterations:
            self.step()
            if between is not None:
                between()
            n += 1

    def step(self) -> ImuSample | None:
        """One iteration: wait for a sample and process it, or handle the watchdog."""
        try:
            sample = self.dev.imu.read_sample(self.cfg.failsafe.imu_timeout_s)
        except OSError as exc:  # the port itself failed (unplugged, I/O error)
            self._port_error("imu", exc)
            time.sleep(self.cfg.failsafe.imu_timeout_s)  # keep the watchdog period, do not spin
            sample = None
        if sample is None:
            self._imu_timeout()
            return None
        self.tick(sample)
        return sample

    def _imu_timeout(self) -> None:
        self.counters["imu_timeouts"] += 1
        self.modes.imu_lost()
        self._log_transitions()
        self._write_esc(None)
        self.log.warning("imu.timeout", timeouts=self.counters["imu_timeouts"], mode=self.modes.mode)

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

    def tick(self, sample: ImuSample) -> None:
        """Process one IMU sample (steps 2-8 of the module docstring)."""
        perf = self._perf_ns
        t_start = perf()
        cfg, dev = self.cfg, self.dev
        t_ns = sample.t_ns
        self.log.t_ns = t_ns
        gap_ns = self.period_ns if self._t_prev_ns is None else t_ns - self._t_prev_ns
        dt_s = gap_ns * 1e-9
        self._t_prev_ns = t_ns
        if sample.skipped:
            self._skipped_in_window = True
        roll, pitch, _yaw = sample.euler_rad
        p, q, r = sample.omega_B_radps
        sphi, cphi = math.sin(roll), math.cos(roll)
        sth, cth = math.sin(pitch), math.cos(pitch)
        roll_rate = p + (q * sphi + r * cphi) * (sth / cth)
        pitch_rate = q * cphi - r * sphi

        # 2. ADC (its blocking reply wait is not compute time)
        t_io = perf()
        try:
            codes = dev.adc.read_codes(t_ns)
        except OSError as exc:
            self._port_error("adc", exc)
            codes = None
        io_ns = perf() - t_io
        z_baro: float | None = None
        f_adxl: tuple[float, float, float] | None = None
        refused = self.plausible.refused
        if codes is None:
            self.plausible.baro_Pa(None)  # no previous reading for the next step test
        else:
            booting = not self.baro_ref.ready  # at rest, averaging: readings for the references only
            p_Pa = self.analog.baro_pressure_Pa(codes[0])
            if p_Pa is None:
                self.counters["baro_out_of_range"] += 1
            p_Pa = self.plausible.baro_Pa(p_Pa)
            f_adxl = self.analog.accel_B_mps2(codes[1], codes[2], codes[3])
            if not self.plausible.accel_in_range(f_adxl):
                f_adxl = None
            elif booting:
                self.accel_zero.add(f_adxl, roll, pitch)
                f_adxl = None
            else:
                f_adxl = self.accel_zero.correct(f_adxl)
            if p_Pa is not None:
                if booting:
                    if self.baro_ref.add(p_Pa, t_ns):
                        self._fix_references()
                else:
                    z_baro = self.baro_ref.altitude_m(p_Pa)

        # 3. RC (non-blocking)
        try:
            dev.rc.poll(t_ns)
        except OSError as exc:
            self._port_error("rc", exc)
        frame = dev.rc.latest
        rc_valid = frame is not None and t_ns - frame.t_ns <= self._rc_loss_ns
        if rc_valid:
            roll_cmd, pitch_cmd, yaw_rate_cmd, z_stick, thr_us, yaw_us = self._sticks(frame.channels_us)
        else:
            roll_cmd = pitch_cmd = yaw_rate_cmd = z_stick = 0.0
            thr_us, yaw_us = cfg.rc.throttle_low_us, cfg.rc.center_us

        # 4. altitude estimate: a_up = -(R_NB f_B)_z - g, tilt-compensated with the IMU attitude
        f_x = sample.f_B_mps2
        a_up_xsens = -(-sth * f_x[0] + sphi * cth * f_x[1] + cphi * cth * f_x[2]) - G0_MPS2
        if math.isfinite(a_up_xsens):  # low-passed for the touchdown test
            self._a_up_lp += dt_s / (ACCEL_LP_TAU_S + dt_s) * (a_up_xsens - self._a_up_lp)
        a_up: float | None = None
        if cfg.kf.accel_source == "xsens":
            a_up = a_up_xsens
        elif f_adxl is not None:
            a_up = -(-sth * f_adxl[0] + sphi * cth * f_adxl[1] + cphi * cth * f_adxl[2]) - G0_MPS2
            # the same airframe's other accelerometer must agree (once the offsets are known)
            if self.baro_ref.ready and not self.plausible.accel_agrees(a_up, a_up_xsens):
                a_up = None
        if self.plausible.refused != refused:  # this sample's ADC reading was (partly) implausible
            self._rare("adc_implausible", "adc.implausible", **self.plausible.counters)
        if self.baro_ref.ready:
            self.kf.predict(self._u_applied)
            # In ground effect the rotor wash over the static port makes the barometer read
            # low: flying (the last sample's mode) below ground_effect_alt_m, trust it less.
            # It can only read low there (overpressure), so a reading below the take-off level
            # says no more than "not below it": it counts as the take-off level, and fully
            # while the estimate has sunk below that floor.
            r_scale = 1.0
            if self.modes.controllers_active and self.kf.z_m < cfg.kf.ground_effect_alt_m and z_baro is not None:
                self.counters["baro_in_ground_effect"] += 1
                z_baro = max(z_baro, 0.0)
                if not (self.kf.z_m < 0.0 and z_baro == 0.0):
                    r_scale = cfg.kf.ground_effect_r_scale
            kc = self.kf.counters
            reanchored = kc["baro_reanchored"]
            if not self.kf.update(z_baro, a_up, r_scale):
                self._rare("baro_rejected", "kf.baro_rejected", innovation_m=(z_baro or 0.0) - self.kf.z_m)
            elif kc["baro_reanchored"] != reanchored:
                self.log.warning("kf.baro_reanchored", count=kc["baro_reanchored"], z_hat_m=self.kf.z_m,
                                 rejected=kc["baro_rejected"])
            # Standing on the ground: at rest since long enough that a landing detected a
            # little above the ground (from this very estimate) has come down by now.
            since = self.modes.resting_since_ns
            if since is not None and t_ns - since >= self._rest_after_ns:
                if since != self._rest_anchored_ns:  # a new rest period
                    self._rest_anchored_ns = since
                    if since > 0:  # after a flight: the touchdown may have fooled the estimate
                        self.kf.loosen_height(cfg.kf.r_baro_m2)
                self.kf.update_at_rest()
            elif self.modes.ground_contact:  # landing, on the ground: it stands still (the last sample's test)
                self.kf.update_at_rest()
        z_hat, vz_hat, az_hat = self.kf.z_m, self.kf.vz_mps, self.kf.az_mps2

        # 5. modes. A landing (the RC failsafe, or the throttle stick at or below the take-off
        # threshold in flight; a lost RC reads as that) is a descent from the lower of the last
        # setpoint and the estimate that goes on below the estimated ground until the modes
        # confirm the touchdown (flightcode.control.landing).
        modes = self.modes
        before = modes.mode
        landing = before is Mode.FAILSAFE_RC or (before is Mode.FLYING and z_stick <= cfg.altitude.takeoff_alt_m)
        if landing:
            if not self.descent.active:
                self.descent.start(min(self._z_ref_m, z_hat))
            z_ref = self.descent.step(dt_s)
        else:
            self.descent.stop()
            z_ref = z_stick
        mode = modes.update(t_ns, baro_ready=self.baro_ref.ready, rc_valid=rc_valid, throttle_us=thr_us,
                            yaw_us=yaw_us, z_ref_m=z_ref, z_hat_m=z_hat, vz_hat_mps=vz_hat,
                            collective=self._collective_applied, hover_collective=self.hover.collective,
                            a_up_mps2=self._a_up_lp)
        if modes.transitions:
            if not modes.controllers_active:
                self.descent.stop()
            self._log_transitions()
        if mode is Mode.FAILSAFE_RC:
            roll_cmd = pitch_cmd = yaw_rate_cmd = 0.0
        self._z_ref_m = z_ref

        # 6. control
        active = modes.controllers_active
        roll_ref: RefState = self.roll_pf.update(roll_cmd)
        pitch_ref: RefState = self.pitch_pf.update(pitch_cmd)
        tau_roll = self.roll_ctl.update(roll_ref, roll, roll_rate, active)
        tau_pitch = self.pitch_ctl.update(pitch_ref, pitch, pitch_rate, active)
        tau_yaw = self.yaw_ctl.update(yaw_rate_cmd, r, active)
        collective = self.lqi.update(z_ref, z_hat, vz_hat, az_hat, active)

        # 7. mix, one ESC write
        policy = modes.motors
        saturated = False
        tau_applied = (0.0, 0.0, 0.0)
        if policy is MotorPolicy.CONTROL:
            mix = self.mixer.mix(collective, (tau_roll, tau_pitch, tau_yaw))
            tau_applied = mix.applied_tau_Nm  # N m on the airframe (telemetry)
            command = mix.applied_command_Nm  # the same in the controllers' units
            self.roll_ctl.set_applied(command[0])
            self.pitch_ctl.set_applied(command[1])
            self.yaw_ctl.set_applied(command[2])
            pulses = dev.esc.pulses_from_throttle(mix.throttle)
            saturated = mix.saturated
            self._collective_applied = mix.applied_collective_throttle
            self._u_applied = self._collective_applied - self.model.d_h
            # steady flight clear of the ground effect teaches the hover collective
            if mode is Mode.FLYING and not landing and not saturated and HoverThrottle.steady(
                    z_hat, vz_hat, az_hat, cfg.kf.ground_effect_alt_m):
                self.hover.update(self._collective_applied, dt_s)
        else:
            level = cfg.esc.idle_us if policy is MotorPolicy.IDLE else cfg.esc.min_us
            pulses = (level, level, level, level)
            self._collective_applied = 0.0
            self._u_applied = 0.0  # on the ground the weight is carried by the ground, not thrust
        self._write_esc(pulses)

        # 8. telemetry on sensor-time slots
        slot = t_ns // self._tel_slot_ns
        if dev.telemetry is not None and slot != self._tel_last_slot:
            self._tel_last_slot = slot
            flags = ((TelemetryFlags.RC_VALID if rc_valid else 0) | (TelemetryFlags.ADC_VALID if codes else 0)
                     | (TelemetryFlags.MIXER_SATURATED if saturated else 0)
                     | (TelemetryFlags.BARO_REF_READY if self.baro_ref.ready else 0)
                     | (TelemetryFlags.ACCEL_FROM_XSENS if cfg.kf.accel_source == "xsens" else 0)
                     | (TelemetryFlags.PAPER_LITERAL_LAW if cfg.attitude.law == "paper_literal" else 0)
                     | (TelemetryFlags.IMU_SAMPLES_SKIPPED if self._skipped_in_window else 0))
            self._skipped_in_window = False
            last_us, max_us, mean_us = self.window.take()
            imu_c = dev.imu.counters
            record = TelemetryRecord(
                self._tel_seq, t_ns, int(mode), int(flags), sample.euler_rad, z_hat, vz_hat,
                z_baro if z_baro is not None else math.nan, roll_ref.angle_rad, pitch_ref.angle_rad,
                yaw_rate_cmd, z_ref, pulses, collective, tau_applied, last_us, max_us, mean_us,
                imu_c["gap_samples"], imu_c["skipped_samples"], dev.adc.counters["failed_reads"],
                self._rc_errors(), dev.telemetry.counters["dropped_busy"] + dev.telemetry.counters["short_writes"])
            self._tel_seq += 1
            try:
                dev.telemetry.send(encode(record))
            except OSError as exc:
                self._port_error("telemetry", exc)

        compute_ns = perf() - t_start - io_ns
        self.window.add(compute_ns)
        if compute_ns > self._stats_max_ns:
            self._stats_max_ns = compute_ns
        if t_ns >= self._stats_next_ns:
            self._stats_next_ns = t_ns + self._stats_ns
            self._log_stats(mode, z_hat)
        self.last = {"mode": mode, "z_ref_m": z_ref, "z_hat_m": z_hat, "pulses_us": pulses, "rc_valid": rc_valid,
                     "z_baro_m": z_baro, "a_up_mps2": a_up, "compute_ns": compute_ns}

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
                      hover_collective=self.hover.collective,
                      rc_errors=self._rc_errors(),
                      telemetry_sent=d.telemetry.counters["sent"] if d.telemetry is not None else 0)
        self._stats_max_ns = 0
