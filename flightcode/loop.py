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
from collections.abc import Callable

from flightcode.control.landing import ACCEL_LP_TAU_S, HoverThrottle
from flightcode.control.reference import RefState
from flightcode.drivers.analog import G0_MPS2
from flightcode.drivers.xsens import ImuSample
from flightcode.loop_parts import Devices, LoopParts, make_devices
from flightcode.modes import Mode, MotorPolicy
from flightcode.telemetry import TelemetryFlags, TelemetryRecord, encode

__all__ = ["Devices", "FlightLoop", "make_devices"]


class FlightLoop(LoopParts):
    """The flight code's main loop on ``devices`` with config ``cfg`` (built by
    :class:`flightcode.loop_parts.LoopParts`).

    Args:
        perf_ns: the compute-time clock (``time.perf_counter_ns``); only measures, never paces.
    """

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

    def tick(self, sample: ImuSample) -> None:
        """Process one IMU sample (steps 2-8 of the module docstring)."""
        t_start = self._perf_ns()
        t_ns = sample.t_ns
        self.log.t_ns = t_ns
        gap_ns = self.period_ns if self._t_prev_ns is None else t_ns - self._t_prev_ns
        dt_s = gap_ns * 1e-9
        self._t_prev_ns = t_ns
        if sample.skipped:
            self._skipped_in_window = True
        roll, pitch, _yaw = sample.euler_rad
        p, q, r = sample.omega_B_radps
        tilt = (math.sin(roll), math.cos(roll), math.sin(pitch), math.cos(pitch))
        sphi, cphi, sth, cth = tilt
        roll_rate = p + (q * sphi + r * cphi) * (sth / cth)
        pitch_rate = q * cphi - r * sphi
        refused = self.plausible.refused
        codes, z_baro, f_adxl, io_ns = self._read_adc(t_ns, roll, pitch)
        rc_valid, (roll_cmd, pitch_cmd, yaw_rate_cmd, z_stick, thr_us, yaw_us) = self._read_rc(t_ns)
        z_baro, a_up = self._estimate_altitude(sample, dt_s, tilt, z_baro, f_adxl, refused)
        z_hat, vz_hat, az_hat = self.kf.z_m, self.kf.vz_mps, self.kf.az_mps2
        mode, z_ref, landing = self._update_modes(t_ns, dt_s, rc_valid, z_stick, thr_us, yaw_us, z_hat,
                                                  vz_hat)
        if mode is Mode.FAILSAFE_RC:
            roll_cmd = pitch_cmd = yaw_rate_cmd = 0.0

        # 6. control
        active = self.modes.controllers_active
        roll_ref: RefState = self.roll_pf.update(roll_cmd)
        pitch_ref: RefState = self.pitch_pf.update(pitch_cmd)
        tau_roll = self.roll_ctl.update(roll_ref, roll, roll_rate, active)
        tau_pitch = self.pitch_ctl.update(pitch_ref, pitch, pitch_rate, active)
        tau_yaw = self.yaw_ctl.update(yaw_rate_cmd, r, active)
        collective = self.lqi.update(z_ref, z_hat, vz_hat, az_hat, active)

        pulses, saturated, tau_applied = self._mix(mode, landing, collective, (tau_roll, tau_pitch, tau_yaw),
                                                   (z_hat, vz_hat, az_hat), dt_s)
        self._write_esc(pulses)
        if self.dev.telemetry is not None and t_ns // self._tel_slot_ns != self._tel_last_slot:
            self._send_telemetry(TelemetryRecord(
                self._tel_seq, t_ns, int(mode), int(self._telemetry_flags(rc_valid, codes, saturated)),
                sample.euler_rad, z_hat, vz_hat, z_baro if z_baro is not None else math.nan, roll_ref.angle_rad,
                pitch_ref.angle_rad, yaw_rate_cmd, z_ref, pulses, collective, tau_applied, *self.window.take(),
                *self._error_counts()))
        compute_ns = self._perf_ns() - t_start - io_ns
        self._account(compute_ns, t_ns, mode, z_hat)
        self.last = {"mode": mode, "z_ref_m": z_ref, "z_hat_m": z_hat, "pulses_us": pulses, "rc_valid": rc_valid,
                     "z_baro_m": z_baro, "a_up_mps2": a_up, "compute_ns": compute_ns}

    # -- the steps of a tick ----------------------------------------------------------------
    def _read_adc(self, t_ns: int, roll: float, pitch: float) -> tuple[
            tuple[int, ...] | None, float | None, tuple[float, float, float] | None, int]:
        """2. The ADC: (codes, barometer altitude m, ADXL335 specific force FRD m/s^2, the
        blocking reply wait in perf ns, which is not compute time). While the references are
        being averaged at rest, the readings go to them only."""
        perf = self._perf_ns
        t_io = perf()
        try:
            codes = self.dev.adc.read_codes(t_ns)
        except OSError as exc:
            self._port_error("adc", exc)
            codes = None
        io_ns = perf() - t_io
        z_baro: float | None = None
        f_adxl: tuple[float, float, float] | None = None
        if codes is None:
            self.plausible.baro_Pa(None)  # no previous reading for the next step test
            return codes, z_baro, f_adxl, io_ns
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
        return codes, z_baro, f_adxl, io_ns

    def _read_rc(self, t_ns: int) -> tuple[bool, tuple[float, float, float, float, float, float]]:
        """3. RC (non-blocking): whether it is valid, and the sticks (:meth:`_sticks`; centred
        and throttle low when it is not)."""
        rc = self.dev.rc
        try:
            rc.poll(t_ns)
        except OSError as exc:
            self._port_error("rc", exc)
        frame = rc.latest
        rc_valid = frame is not None and t_ns - frame.t_ns <= self._rc_loss_ns
        if frame is not None and rc_valid:
            return rc_valid, self._sticks(frame.channels_us)
        return rc_valid, (0.0, 0.0, 0.0, 0.0, self.cfg.rc.throttle_low_us, self.cfg.rc.center_us)

    def _estimate_altitude(self, sample: ImuSample, dt_s: float, tilt: tuple[float, float, float, float],
                           z_baro: float | None, f_adxl: tuple[float, float, float] | None,
                           refused: int) -> tuple[float | None, float | None]:
        """4. The altitude estimate: a_up = -(R_NB f_B)_z - g, tilt-compensated with the IMU
        attitude (``tilt``: sin, cos of roll, sin, cos of pitch). Returns the barometer altitude
        as the estimator took it (held at the take-off level in ground effect) and a_up (m/s^2,
        None: not used)."""
        cfg = self.cfg
        sphi, cphi, sth, cth = tilt
        f_x = sample.f_B_mps2
        a_up_xsens = -(-sth * f_x[0] + sphi * cth * f_x[1] + cphi * cth * f_x[2]) - G0_MPS2
        if math.isfinite(a_up_xsens):  # low-passed for the touchdown test
            self._a_up_lp += dt_s / (ACCEL_LP_TAU_S + dt_s) * (a_up_xsens - self._a_up_lp)
        a_up: float | None = None
        if cfg.kf.accel_source == "xsens":
            a_up = a_up_xsens
        elif f_adxl is not None:
            a_up = -(-sth * f_adxl[0] + sphi * cth * f_adxl[1] + cphi * cth * f_adxl[2]) - G0_MPS2
            # the same airframe's other accelerometer must agree (once the offsets are known),
            # sample by sample and in the mean: an ADXL335 whose offset moved is replaced by it
            if self.baro_ref.ready:
                if not self.plausible.accel_agrees(a_up, a_up_xsens):
                    a_up = None
                elif not self.plausible.accel_offset_holds(a_up, a_up_xsens):
                    a_up = a_up_xsens
        if self.plausible.refused != refused:  # this sample's ADC reading was (partly) implausible
            self._rare("adc_implausible", "adc.implausible", **self.plausible.counters)
        if self.baro_ref.ready:
            z_baro = self._update_kf(sample.t_ns, dt_s, z_baro, a_up)
        return z_baro, a_up

    def _update_kf(self, t_ns: int, dt_s: float, z_baro: float | None, a_up: float | None) -> float | None:
        """The estimator's predict and updates (barometer, acceleration, at rest); returns the
        barometer altitude as it took it (None: refused)."""
        cfg = self.cfg
        self.kf.predict(self._u_applied)
        z_baro = self._check_baro_motion(dt_s, z_baro, a_up)
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
            if self.baro_motion is not None:
                self.baro_motion.reading_rejected()
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
        return z_baro

    def _update_modes(self, t_ns: int, dt_s: float, rc_valid: bool, z_stick: float, thr_us: float,
                      yaw_us: float, z_hat: float, vz_hat: float) -> tuple[Mode, float, bool]:
        """5. Modes: (the mode, the altitude setpoint m, whether landing). A landing (the RC
        failsafe, or the throttle stick at or below the take-off threshold in flight; a lost
        RC reads as that) is a descent from the lower of the last setpoint and the estimate
        that goes on below the estimated ground until the modes confirm the touchdown
        (flightcode.control.landing)."""
        modes = self.modes
        before = modes.mode
        landing = before is Mode.FAILSAFE_RC or (before is Mode.FLYING and z_stick <= self.cfg.altitude.takeoff_alt_m)
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
        self._z_ref_m = z_ref
        return mode, z_ref, landing

    def _mix(self, mode: Mode, landing: bool, collective: float, tau: tuple[float, float, float],
             z: tuple[float, float, float], dt_s: float) -> tuple[tuple[float, ...], bool, tuple[float, float, float]]:
        """7. The mix: (ESC pulses us, whether the mixer saturated, torques applied N m). ``z``:
        the estimated height m, climb m/s and vertical acceleration m/s^2."""
        cfg = self.cfg
        policy = self.modes.motors
        if policy is not MotorPolicy.CONTROL:
            level = cfg.esc.idle_us if policy is MotorPolicy.IDLE else cfg.esc.min_us
            self._collective_applied = 0.0
            self._u_applied = 0.0  # on the ground the weight is carried by the ground, not thrust
            return (level, level, level, level), False, (0.0, 0.0, 0.0)
        mix = self.mixer.mix(collective, tau)
        command = mix.applied_command_Nm  # the applied torques in the controllers' units
        self.roll_ctl.set_applied(command[0])
        self.pitch_ctl.set_applied(command[1])
        self.yaw_ctl.set_applied(command[2])
        pulses = self.dev.esc.pulses_from_throttle(mix.throttle)
        self._collective_applied = mix.applied_collective_throttle
        self._u_applied = self._collective_applied - self.model.d_h
        # steady flight clear of the ground effect teaches the hover collective
        if mode is Mode.FLYING and not landing and not mix.saturated and HoverThrottle.steady(
                z[0], z[1], z[2], cfg.kf.ground_effect_alt_m):
            self.hover.update(self._collective_applied, dt_s)
        return pulses, mix.saturated, mix.applied_tau_Nm  # N m on the airframe (telemetry)

    def _telemetry_flags(self, rc_valid: bool, codes: tuple[int, ...] | None, saturated: bool) -> int:
        cfg = self.cfg
        flags = ((TelemetryFlags.RC_VALID if rc_valid else 0) | (TelemetryFlags.ADC_VALID if codes else 0)
                 | (TelemetryFlags.MIXER_SATURATED if saturated else 0)
                 | (TelemetryFlags.BARO_REF_READY if self.baro_ref.ready else 0)
                 | (TelemetryFlags.ACCEL_FROM_XSENS if cfg.kf.accel_source == "xsens" or self.plausible.offset_moved else 0)
                 | (TelemetryFlags.PAPER_LITERAL_LAW if cfg.attitude.law == "paper_literal" else 0)
                 | (TelemetryFlags.IMU_SAMPLES_SKIPPED if self._skipped_in_window else 0)
                 | (TelemetryFlags.BARO_MOTION_REFUSED if self.baro_motion and self.baro_motion.refusing else 0))
        self._skipped_in_window = False
        return flags

    def _error_counts(self) -> tuple[int, int, int, int, int]:
        """IMU gaps and skipped samples, failed ADC reads, RC errors, telemetry not sent."""
        d = self.dev
        assert d.telemetry is not None
        imu_c = d.imu.counters
        return (imu_c["gap_samples"], imu_c["skipped_samples"], d.adc.counters["failed_reads"], self._rc_errors(),
                d.telemetry.counters["dropped_busy"] + d.telemetry.counters["short_writes"])

    def _send_telemetry(self, record: TelemetryRecord) -> None:
        """8. Telemetry, once per sensor-time slot of ``telemetry.divider`` samples."""
        assert self.dev.telemetry is not None
        self._tel_last_slot = record.t_ns // self._tel_slot_ns
        self._tel_seq += 1
        try:
            self.dev.telemetry.send(encode(record))
        except OSError as exc:
            self._port_error("telemetry", exc)

    def _account(self, compute_ns: int, t_ns: int, mode: Mode, z_hat: float) -> None:
        """The iteration's compute time into the telemetry window and the periodic stats."""
        self.window.add(compute_ns)
        if compute_ns > self._stats_max_ns:
            self._stats_max_ns = compute_ns
        if t_ns >= self._stats_next_ns:
            self._stats_next_ns = t_ns + self._stats_ns
            self._log_stats(mode, z_hat)
