/* The loop's steps on each sample: see loop.h. */
#include "loop.h"

#include <math.h>
#include <string.h>

#include "log.h"
#include "loop_parts.h"

typedef struct {
    float roll, pitch;
    float sphi, cphi, sth, cth;
} tilt_t;

/* 2. The ADC: whether codes came, the barometric altitude (m) and the ADXL335's specific
 * force (FRD, m/s^2), each only when believable; the blocking reply wait in *io_ns. While the
 * references are averaged at rest, the readings go to them only. */
static bool read_adc(flight_loop_t *L, int64_t t_ns, const tilt_t *tilt, bool *have_baro, float *z_baro,
                     bool *have_f, float f_adxl[3], uint64_t *io_ns)
{
    uint16_t codes[MCP3204_CHANNELS];
    uint64_t t_io = hal_now_ns();
    int r = mcp3204_read(&L->adc, (uint64_t)t_ns, codes);
    float p_Pa = 0.0f;
    bool booting = !L->baro_ref.ready, have_p;
    *io_ns = hal_now_ns() - t_io;
    *have_baro = *have_f = false;
    if (r < 0)
        loop_port_error(&L->counters.adc_port_errors, "adc");
    if (r <= 0) {
        plausibility_baro_Pa(&L->plausible, false, 0.0f); /* no previous reading for the next step test */
        return false;
    }
    have_p = analog_baro_Pa(&L->analog, codes[0], &p_Pa);
    if (!have_p)
        L->counters.baro_out_of_range++;
    have_p = plausibility_baro_Pa(&L->plausible, have_p, p_Pa);
    analog_accel_B(&L->analog, codes[1], codes[2], codes[3], f_adxl);
    if (plausibility_accel_in_range(&L->plausible, f_adxl)) {
        if (booting) {
            accel_offset_add(&L->accel_zero, f_adxl, tilt->roll, tilt->pitch);
        } else {
            accel_offset_correct(&L->accel_zero, f_adxl);
            *have_f = true;
        }
    }
    if (have_p) {
        if (booting) {
            if (baro_ref_add(&L->baro_ref, p_Pa, t_ns))
                loop_fix_references(L);
        } else {
            *z_baro = baro_ref_altitude_m(&L->baro_ref, p_Pa);
            *have_baro = true;
        }
    }
    return true;
}

/* 3. RC (non-blocking): whether it is valid; the sticks (centred, throttle low when not). */
static bool read_rc(flight_loop_t *L, int64_t t_ns, float sticks[6])
{
    const fc_config_t *cfg = L->cfg;
    const rc_frame_t *frame = &L->rc.latest;
    bool valid;
    if (rc_poll(&L->rc, t_ns) < 0)
        loop_port_error(&L->counters.rc_port_errors, "rc");
    valid = frame->valid && t_ns - frame->t_ns <= L->rc_loss_ns;
    if (valid && frame->n > L->ch[0] && frame->n > L->ch[1] && frame->n > L->ch[2] && frame->n > L->ch[3]) {
        loop_sticks(L, frame->channels_us, sticks);
        return true;
    }
    sticks[0] = sticks[1] = sticks[2] = sticks[3] = 0.0f;
    sticks[4] = cfg->rc.throttle_low_us;
    sticks[5] = cfg->rc.center_us;
    return false;
}

/* The barometer against the accelerometers' motion: whether the reading may be fused. */
static bool check_baro_motion(flight_loop_t *L, int64_t dt_ns, bool have_baro, float z_baro, bool have_a,
                              float a_up)
{
    baro_motion_t *bm = &L->baro_motion;
    altitude_kf_t *kf = &L->kf;
    bool judging, was_refusing;
    float z_to, vz_to;
    if (!L->baro_motion_on)
        return have_baro;
    if (!modes_controllers_active(&L->modes)) {
        baro_motion_on_ground(bm);
        return have_baro;
    }
    judging = altitude_kf_z_m(kf) >= L->cfg->kf.ground_effect_alt_m && !L->modes.ground_contact;
    was_refusing = bm->refusing;
    if (!baro_motion_add(bm, dt_ns, have_baro, z_baro, have_a, a_up, altitude_kf_z_m(kf), altitude_kf_vz_mps(kf),
                         judging)) {
        if (was_refusing && log_begin(LOG_INFO, "baro.motion_agrees")) {
            log_float("z_hat_m", altitude_kf_z_m(kf));
            if (have_baro)
                log_float("z_baro_m", z_baro);
            else
                log_str("z_baro_m", "None");
            log_int("refused", L->counters.baro_motion_refused);
            log_end();
        }
        return have_baro;
    }
    if (baro_motion_take_reanchor(bm, &z_to, &vz_to)) {
        float sd = bm->p.max_m / 3.0f; /* the inertial height is good to the check's tolerance */
        if (log_begin(LOG_WARNING, "baro.motion_disagrees")) {
            log_float("z_hat_m", altitude_kf_z_m(kf));
            log_float("z_inertial_m", z_to);
            log_float("vz_inertial_mps", vz_to);
            if (have_baro)
                log_float("z_baro_m", z_baro);
            else
                log_str("z_baro_m", "None");
            log_end();
        }
        altitude_kf_move_to(kf, z_to, vz_to, sd * sd, BARO_MOTION_VZ_VAR);
    }
    if (have_baro)
        L->counters.baro_motion_refused++;
    return false;
}

/* The estimator's predict and updates; returns whether (and *z_baro as) it took the barometer. */
static bool update_kf(flight_loop_t *L, int64_t t_ns, int64_t dt_ns, bool have_baro, float *z_baro, bool have_a,
                      float a_up)
{
    const fc_config_t *cfg = L->cfg;
    altitude_kf_t *kf = &L->kf;
    float r_scale = 1.0f;
    uint32_t reanchored = kf->counters.baro_reanchored;
    modes_t *m = &L->modes;
    altitude_kf_predict(kf, L->u_applied);
    have_baro = check_baro_motion(L, dt_ns, have_baro, *z_baro, have_a, a_up);
    /* In ground effect the rotor wash over the static port makes the barometer read low:
     * flying below ground_effect_alt_m, trust it less. It can only read low there, so a
     * reading below the take-off level counts as the take-off level, and fully while the
     * estimate itself has sunk below that floor. */
    if (modes_controllers_active(m) && altitude_kf_z_m(kf) < cfg->kf.ground_effect_alt_m && have_baro) {
        L->counters.baro_in_ground_effect++;
        if (*z_baro < 0.0f)
            *z_baro = 0.0f;
        if (!(altitude_kf_z_m(kf) < 0.0f && *z_baro == 0.0f))
            r_scale = cfg->kf.ground_effect_r_scale;
    }
    if (!altitude_kf_update(kf, have_baro, *z_baro, have_a, a_up, r_scale)) {
        if (L->baro_motion_on)
            baro_motion_reading_rejected(&L->baro_motion);
        if (loop_rare(&L->counters.baro_rejected_logged) && log_begin(LOG_WARNING, "kf.baro_rejected")) {
            log_int("count", L->counters.baro_rejected_logged);
            log_float("innovation_m", (have_baro ? *z_baro : 0.0f) - altitude_kf_z_m(kf));
            log_end();
        }
    } else if (kf->counters.baro_reanchored != reanchored && log_begin(LOG_WARNING, "kf.baro_reanchored")) {
        log_int("count", kf->counters.baro_reanchored);
        log_float("z_hat_m", altitude_kf_z_m(kf));
        log_int("rejected", kf->counters.baro_rejected);
        log_end();
    }
    /* Standing on the ground: at rest since long enough that a landing detected a little
     * above the ground (from this very estimate) has come down by now. */
    if (m->resting && t_ns - m->resting_since_ns >= L->rest_after_ns) {
        if (!L->rest_anchored || m->resting_since_ns != L->rest_anchored_ns) { /* a new rest period */
            L->rest_anchored = true;
            L->rest_anchored_ns = m->resting_since_ns;
            if (m->resting_since_ns > 0) /* after a flight: the touchdown may have fooled the estimate */
                altitude_kf_loosen_height(kf, cfg->kf.r_baro_m2);
        }
        altitude_kf_update_at_rest(kf);
    } else if (m->ground_contact) { /* landing, on the ground: it stands still (the last sample's test) */
        altitude_kf_update_at_rest(kf);
    }
    return have_baro;
}

/* 4. The altitude estimate: a_up = -(R_NB f_B)_z - g, tilt-compensated with the IMU attitude.
 * Returns whether the estimator took a barometer reading (*z_baro as taken). */
static bool estimate_altitude(flight_loop_t *L, const imu_sample_t *s, int64_t dt_ns, float dt_s, const tilt_t *t,
                              bool have_baro, float *z_baro, bool have_f, const float f_adxl[3], uint32_t refused)
{
    const fc_config_t *cfg = L->cfg;
    const float *fx = s->f_B_mps2;
    float a_up_xsens = -(-t->sth * fx[0] + t->sphi * t->cth * fx[1] + t->cphi * t->cth * fx[2]) - G0_MPS2;
    float a_up = 0.0f;
    bool have_a = false;
    touchdown_accel_update(&L->a_up_lp, a_up_xsens, dt_s); /* low-passed for the touchdown test */
    if (cfg->kf.accel_source == CFG_ACCEL_XSENS) {
        a_up = a_up_xsens;
        have_a = true;
    } else if (have_f) {
        a_up = -(-t->sth * f_adxl[0] + t->sphi * t->cth * f_adxl[1] + t->cphi * t->cth * f_adxl[2]) - G0_MPS2;
        have_a = true;
        /* the same airframe's other accelerometer must agree (once the offsets are known),
         * sample by sample and in the mean: an ADXL335 whose offset moved is replaced by it */
        if (L->baro_ref.ready) {
            if (!plausibility_accel_agrees(&L->plausible, a_up, a_up_xsens))
                have_a = false;
            else if (!plausibility_accel_offset_holds(&L->plausible, a_up, a_up_xsens))
                a_up = a_up_xsens;
        }
    }
    if (plausibility_refused(&L->plausible) != refused && loop_rare(&L->counters.adc_implausible) &&
        log_begin(LOG_WARNING, "adc.implausible")) {
        const plausibility_counters_t *c = &L->plausible.counters;
        log_int("count", L->counters.adc_implausible);
        log_int("baro_out_of_range", c->baro_out_of_range);
        log_int("baro_flat", c->baro_flat);
        log_int("baro_step", c->baro_step);
        log_int("accel_out_of_range", c->accel_out_of_range);
        log_int("accel_disagrees_xsens", c->accel_disagrees_xsens);
        log_int("accel_offset_moved", c->accel_offset_moved);
        log_end();
    }
    if (L->baro_ref.ready)
        return update_kf(L, s->t_ns, dt_ns, have_baro, z_baro, have_a, a_up);
    return have_baro;
}

/* 5. Modes: the mode, the altitude setpoint (m) and whether a landing is flown. */
static fc_mode_t update_modes(flight_loop_t *L, int64_t t_ns, float dt_s, bool rc_valid, const float sticks[6],
                              float z_hat, float vz_hat, float *z_ref, bool *landing)
{
    modes_t *m = &L->modes;
    fc_mode_t before = m->mode, mode;
    modes_input_t in;
    *landing = before == MODE_FAILSAFE_RC ||
               (before == MODE_FLYING && sticks[3] <= L->cfg->altitude.takeoff_alt_m);
    if (*landing) {
        if (!L->descent.active)
            landing_descent_start(&L->descent, L->z_ref_m < z_hat ? L->z_ref_m : z_hat);
        *z_ref = landing_descent_step(&L->descent, dt_s);
    } else {
        landing_descent_stop(&L->descent);
        *z_ref = sticks[3];
    }
    in.baro_ready = L->baro_ref.ready;
    in.rc_valid = rc_valid;
    in.throttle_us = sticks[4];
    in.yaw_us = sticks[5];
    in.z_ref_m = *z_ref;
    in.z_hat_m = z_hat;
    in.vz_hat_mps = vz_hat;
    in.collective = L->collective_applied;
    in.hover_collective = L->hover.collective;
    in.a_up_mps2 = L->a_up_lp.a_up_mps2;
    mode = modes_update(m, t_ns, &in);
    if (m->n_transitions) {
        if (!modes_controllers_active(m))
            landing_descent_stop(&L->descent);
        loop_log_transitions(L);
    }
    L->z_ref_m = *z_ref;
    return mode;
}

/* 7. The mix: ESC pulses (us), whether the mixer saturated, torques applied (N m). */
static bool mix(flight_loop_t *L, fc_mode_t mode, bool landing, float collective, const float tau[3], float z_hat,
                float vz_hat, float az_hat, float dt_s, float pulses[4], float tau_applied[3])
{
    const fc_config_t *cfg = L->cfg;
    motor_policy_t policy = modes_motors(&L->modes);
    mixer_out_t out;
    float lo = cfg->esc.min_us, span = cfg->esc.max_us - cfg->esc.min_us;
    if (policy != MOTORS_CONTROL) {
        float level = policy == MOTORS_IDLE ? cfg->esc.idle_us : cfg->esc.min_us;
        L->collective_applied = 0.0f;
        L->u_applied = 0.0f; /* on the ground the weight is carried by the ground, not thrust */
        for (int i = 0; i < 4; i++)
            pulses[i] = level;
        tau_applied[0] = tau_applied[1] = tau_applied[2] = 0.0f;
        return false;
    }
    mixer_mix(&L->mixer, collective, tau, &out);
    memory_attitude_set_applied(&L->roll_ctl, out.applied_command_Nm[0]);
    memory_attitude_set_applied(&L->pitch_ctl, out.applied_command_Nm[1]);
    yaw_rate_set_applied(&L->yaw_ctl, out.applied_command_Nm[2]);
    for (int i = 0; i < 4; i++) {
        float d = out.throttle[i];
        d = d > 1.0f ? 1.0f : d < 0.0f ? 0.0f : d;
        pulses[i] = lo + span * d;
    }
    L->collective_applied = out.applied_collective_throttle;
    L->u_applied = L->collective_applied - L->d_h;
    /* steady flight clear of the ground effect teaches the hover collective */
    if (mode == MODE_FLYING && !landing && !out.saturated &&
        hover_throttle_steady(z_hat, vz_hat, az_hat, cfg->kf.ground_effect_alt_m))
        hover_throttle_update(&L->hover, L->collective_applied, dt_s);
    memcpy(tau_applied, out.applied_tau_Nm, sizeof out.applied_tau_Nm);
    return out.saturated;
}

static uint16_t telemetry_flags(flight_loop_t *L, bool rc_valid, bool adc_valid, bool saturated)
{
    const fc_config_t *cfg = L->cfg;
    uint16_t flags = (uint16_t)((rc_valid ? TM_RC_VALID : 0) | (adc_valid ? TM_ADC_VALID : 0) |
                                (saturated ? TM_MIXER_SATURATED : 0) | (L->baro_ref.ready ? TM_BARO_REF_READY : 0) |
                                (cfg->kf.accel_source == CFG_ACCEL_XSENS || L->plausible.offset_moved ? TM_ACCEL_FROM_XSENS : 0) |
                                (cfg->attitude.law == CFG_LAW_PAPER_LITERAL ? TM_PAPER_LITERAL_LAW : 0) |
                                (L->skipped_in_window ? TM_IMU_SAMPLES_SKIPPED : 0) |
                                (L->baro_motion_on && L->baro_motion.refusing ? TM_BARO_MOTION_REFUSED : 0));
    L->skipped_in_window = false;
    return flags;
}

/* 8. Telemetry, once per sensor-time slot of telemetry.divider samples. */
static void send_telemetry(flight_loop_t *L, telemetry_record_t *rec)
{
    uint8_t payload[TELEMETRY_PAYLOAD_LEN];
    L->tel_last_slot = rec->t_ns / L->tel_slot_ns;
    rec->seq = L->tel_seq++; /* the first frame is 0, as flightcode's */
    telemetry_encode(rec, payload);
    if (xbee_link_send(&L->telemetry, payload, sizeof payload) < 0)
        loop_port_error(&L->counters.telemetry_port_errors, "telemetry");
}

void loop_tick(flight_loop_t *L, const imu_sample_t *s)
{
    uint64_t t_start = hal_now_ns(), io_ns = 0, compute_ns;
    int64_t t_ns = s->t_ns;
    int64_t gap_ns = L->have_t_prev ? t_ns - L->t_prev_ns : L->period_ns;
    float dt_s = (float)gap_ns * 1e-9f;
    tilt_t tilt;
    float roll_rate, pitch_rate, z_baro = 0.0f, f_adxl[3], sticks[6], z_hat, vz_hat, az_hat, z_ref;
    float tau[3], tau_applied[3], pulses[4], collective;
    bool have_baro, have_f, adc_valid, rc_valid, landing, saturated, active;
    uint32_t refused = plausibility_refused(&L->plausible);
    ref_state_t roll_ref, pitch_ref;
    fc_mode_t mode;
    const float *w = s->omega_B_radps;

    log_set_time_ns(t_ns);
    L->have_t_prev = true;
    L->t_prev_ns = t_ns;
    if (s->skipped)
        L->skipped_in_window = true;
    tilt.roll = s->euler_rad[0];
    tilt.pitch = s->euler_rad[1];
    tilt.sphi = sinf(tilt.roll);
    tilt.cphi = cosf(tilt.roll);
    tilt.sth = sinf(tilt.pitch);
    tilt.cth = cosf(tilt.pitch);
    roll_rate = w[0] + (w[1] * tilt.sphi + w[2] * tilt.cphi) * (tilt.sth / tilt.cth);
    pitch_rate = w[1] * tilt.cphi - w[2] * tilt.sphi;
    adc_valid = read_adc(L, t_ns, &tilt, &have_baro, &z_baro, &have_f, f_adxl, &io_ns);
    rc_valid = read_rc(L, t_ns, sticks);
    have_baro = estimate_altitude(L, s, gap_ns, dt_s, &tilt, have_baro, &z_baro, have_f, f_adxl, refused);
    z_hat = altitude_kf_z_m(&L->kf);
    vz_hat = altitude_kf_vz_mps(&L->kf);
    az_hat = altitude_kf_az_mps2(&L->kf);
    mode = update_modes(L, t_ns, dt_s, rc_valid, sticks, z_hat, vz_hat, &z_ref, &landing);
    if (mode == MODE_FAILSAFE_RC)
        sticks[0] = sticks[1] = sticks[2] = 0.0f;

    /* 6. control */
    active = modes_controllers_active(&L->modes);
    roll_ref = prefilter3_update(&L->roll_pf, sticks[0]);
    pitch_ref = prefilter3_update(&L->pitch_pf, sticks[1]);
    tau[0] = memory_attitude_update(&L->roll_ctl, &roll_ref, tilt.roll, roll_rate, active);
    tau[1] = memory_attitude_update(&L->pitch_ctl, &pitch_ref, tilt.pitch, pitch_rate, active);
    tau[2] = yaw_rate_update(&L->yaw_ctl, sticks[2], w[2], active);
    collective = lqi_altitude_update(&L->lqi, z_ref, z_hat, vz_hat, az_hat, active);

    saturated = mix(L, mode, landing, collective, tau, z_hat, vz_hat, az_hat, dt_s, pulses, tau_applied);
    loop_write_esc(L, pulses);
    if (L->telemetry_on && t_ns / L->tel_slot_ns != L->tel_last_slot) {
        telemetry_record_t rec;
        memset(&rec, 0, sizeof rec);
        rec.t_ns = t_ns;
        rec.mode = (uint8_t)mode;
        rec.flags = telemetry_flags(L, rc_valid, adc_valid, saturated);
        memcpy(rec.euler_rad, s->euler_rad, sizeof rec.euler_rad);
        rec.z_hat_m = z_hat;
        rec.vz_hat_mps = vz_hat;
        rec.z_baro_m = have_baro ? z_baro : NAN;
        rec.roll_ref_rad = roll_ref.angle_rad;
        rec.pitch_ref_rad = pitch_ref.angle_rad;
        rec.yaw_rate_ref_radps = sticks[2];
        rec.z_ref_m = z_ref;
        memcpy(rec.pulses_us, L->last.pulses_us, sizeof rec.pulses_us);
        rec.collective = collective;
        memcpy(rec.tau_applied_Nm, tau_applied, sizeof rec.tau_applied_Nm);
        compute_window_take(&L->window, &rec.compute_last_us, &rec.compute_max_us, &rec.compute_mean_us);
        rec.imu_gap_samples = L->imu.counters.gap_samples;
        rec.imu_skipped_samples = L->imu.counters.skipped_samples;
        rec.adc_failed_reads = L->adc.counters.failed_reads;
        rec.rc_errors = rc_errors(&L->rc);
        rec.telemetry_dropped = loop_telemetry_dropped(L);
        send_telemetry(L, &rec);
    }
    compute_ns = hal_now_ns() - t_start - io_ns;
    compute_window_add(&L->window, compute_ns);
    if (compute_ns > L->stats_max_ns)
        L->stats_max_ns = compute_ns;
    if (t_ns >= L->stats_next_ns) {
        L->stats_next_ns = t_ns + L->stats_ns;
        loop_log_stats(L, mode, z_hat);
    }
    L->last.mode = mode;
    L->last.z_ref_m = z_ref;
    L->last.z_hat_m = z_hat;
    L->last.z_baro_m = have_baro ? z_baro : NAN;
    L->last.rc_valid = rc_valid;
    L->last.adc_valid = adc_valid;
    L->last.compute_ns = compute_ns;
}

static void imu_timeout(flight_loop_t *L)
{
    L->counters.imu_timeouts++;
    modes_imu_lost(&L->modes);
    loop_log_transitions(L);
    loop_write_esc(L, NULL);
    if (log_begin(LOG_WARNING, "imu.timeout")) {
        log_int("timeouts", L->counters.imu_timeouts);
        log_str("mode", mode_name(L->modes.mode));
        log_end();
    }
}

void loop_step(flight_loop_t *L)
{
    imu_sample_t sample;
    uint64_t timeout_ns = (uint64_t)cfg_ns(L->cfg->failsafe.imu_timeout_s);
    int r = xsens_read_sample(&L->imu, timeout_ns, &sample);
    if (r < 0) { /* the port itself failed (unplugged, I/O error) */
        loop_port_error(&L->counters.imu_port_errors, "imu");
        hal_sleep_ns(timeout_ns); /* keep the watchdog period, do not spin */
    }
    if (r <= 0) {
        if (!hal_stop_requested()) /* a stop request interrupts the wait: not an IMU loss */
            imu_timeout(L);
        return;
    }
    loop_tick(L, &sample);
}
