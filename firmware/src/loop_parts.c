/* The loop's parts: building them from the config, the boot, and the services of its steps. */
#include "loop_parts.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fc_design.h"
#include "log.h"

#define DEG_F 0.017453292519943295f


/* The design inputs of the generated header must be this config's (flightcode designs them
 * at start-up from the config; the firmware was built from one). */
static bool design_matches(const fc_config_t *cfg, cfg_error_t *err)
{
#define CHECK_INPUT(dotted, member, value) \
    if (fabs((double)cfg->member - (double)(value)) > 1e-6 * fabs((double)(value)) + 1e-12) { \
        snprintf(err->key, sizeof err->key, "%s", dotted); \
        snprintf(err->reason, sizeof err->reason, \
                 "is a design input of this build (firmware/gen made the gains for %g, the config says %g): " \
                 "rebuild with FLIGHT_CONFIG=<this config> (make -C firmware FLIGHT_CONFIG=...)", \
                 (double)(value), (double)cfg->member); \
        return false; \
    }
    FC_DESIGN_INPUTS(CHECK_INPUT)
#undef CHECK_INPUT
    return true;
}

static bool fail(cfg_error_t *err, const char *key, const char *reason)
{
    snprintf(err->key, sizeof err->key, "%s", key);
    snprintf(err->reason, sizeof err->reason, "%s", reason);
    return false;
}

bool loop_init(flight_loop_t *L, const fc_config_t *cfg, cfg_error_t *err)
{
    float T_s = cfg_T_s(cfg);
    memory_attitude_gains_t gains;
    prefilter3_params_t pf;
    yaw_rate_params_t yp;
    lqi_altitude_params_t lp;
    altitude_kf_params_t kp;
    plausibility_params_t pp;
    baro_motion_params_t bp;
    mixer_params_t mp;
    modes_params_t mo;
    xsens_params_t xp;
    baro_chain_params_t baro;
    accel_chain_params_t accel;
    const char *mount[3] = {cfg->adc.accel.mount_B[0], cfg->adc.accel.mount_B[1], cfg->adc.accel.mount_B[2]};
    uint8_t channels[4] = {(uint8_t)cfg->adc.baro_channel, (uint8_t)cfg->adc.accel_channels[0],
                           (uint8_t)cfg->adc.accel_channels[1], (uint8_t)cfg->adc.accel_channels[2]};

    memset(L, 0, sizeof *L);
    L->cfg = cfg;
    if (!design_matches(cfg, err))
        return false;
    L->period_ns = (int64_t)llround(1e9 / (double)cfg->imu.rate_hz);
    /* attitude */
    if (cfg->attitude.law == CFG_LAW_GENERALISED) {
        if (!memory_attitude_gains_from_poles(&gains, T_s, cfg->attitude.omega1_radps, cfg->attitude.omega2_radps,
                                              cfg->attitude.k0_per_s, cfg->attitude.J_hat_kgm2, cfg->attitude.tau_ff_s,
                                              cfg->attitude.u_limit_Nm))
            return fail(err, "attitude", "these gains cannot be flown");
    } else if (!memory_attitude_gains_paper_literal(&gains, T_s, cfg->attitude.k0_per_s, cfg->attitude.J_hat_kgm2,
                                                    cfg->attitude.u_limit_Nm)) {
        return fail(err, "attitude", "these gains cannot be flown");
    }
    memory_attitude_init(&L->roll_ctl, &gains);
    memory_attitude_init(&L->pitch_ctl, &gains);
    if (!prefilter3_params_make(&pf, cfg->attitude.prefilter_omega_radps, T_s))
        return fail(err, "attitude.prefilter_omega_radps", "no prefilter for this bandwidth");
    prefilter3_init(&L->roll_pf, &pf);
    prefilter3_init(&L->pitch_pf, &pf);
    yp.kp_Nm_per_radps = cfg->yaw.kp_Nm_per_radps;
    yp.ki_Nm_per_rad = cfg->yaw.ki_Nm_per_rad;
    yp.u_limit_Nm = cfg->yaw.u_limit_Nm;
    yp.T_s = T_s;
    if (!yaw_rate_init(&L->yaw_ctl, &yp))
        return fail(err, "yaw", "these gains cannot be flown");
    /* altitude */
    if (!lqi_altitude_params_make(&lp, &FC_DESIGN_LQI_GAINS, T_s, cfg->vehicle.m_kg, cfg->vehicle.F_max_N))
        return fail(err, "vehicle.F_max_N", "no hover throttle for this mass and thrust");
    lqi_altitude_init(&L->lqi, &lp);
    L->d_h = lp.d_h;
    kp.model = &FC_DESIGN_KF_MODEL;
    kp.r_baro_m2 = cfg->kf.r_baro_m2;
    kp.r_acc_m2ps4 = cfg->kf.r_acc;
    kp.r_rest_vz_m2ps2 = cfg->kf.r_rest_vz;
    kp.baro_gate_chi2 = cfg->kf.baro_gate_chi2;
    /* round(timeout / T) half to even, as flightcode */
    kp.baro_gate_max_rejects = altitude_kf_gate_max_rejects(cfg_ns(cfg->kf.baro_gate_timeout_s), L->period_ns);
    altitude_kf_init(&L->kf, &kp);
    pp.baro_max_step_Pa = cfg->plausibility.baro_max_step_Pa;
    pp.baro_flat_readings = (uint16_t)cfg->plausibility.baro_flat_readings;
    pp.baro_flat_std_Pa = cfg->plausibility.baro_flat_std_Pa;
    pp.accel_max_g = cfg->plausibility.accel_max_g;
    pp.accel_xsens_tolerance_mps2 = cfg->plausibility.accel_xsens_tolerance_mps2;
    pp.accel_offset_tau_s = cfg->plausibility.accel_offset_tau_s;
    pp.accel_offset_max_mps2 = cfg->plausibility.accel_offset_max_mps2;
    pp.T_s = (float)L->period_ns * 1e-9f;
    if (cfg->plausibility.baro_flat_readings > FLAT_LINE_MAX_READINGS || !plausibility_init(&L->plausible, &pp))
        return fail(err, "plausibility.baro_flat_readings", "beyond what this build's flat-line window holds");
    L->baro_motion_on = cfg->plausibility.baro_motion_window_s > 0.0f;
    if (!baro_motion_params_make(&bp, cfg_ns(cfg->plausibility.baro_motion_window_s),
                                 cfg_ns(cfg->plausibility.baro_motion_block_s), cfg->plausibility.baro_motion_max_m))
        return fail(err, "plausibility.baro_motion_window_s", "beyond what this build's window ring holds");
    baro_motion_init(&L->baro_motion, &bp);
    mp.frame = cfg->vehicle.frame == CFG_FRAME_X ? MIXER_FRAME_X : MIXER_FRAME_PLUS;
    mp.arm_m = cfg->vehicle.arm_m;
    mp.F_max_motor_N = cfg->vehicle.F_max_N / 4.0f;
    mp.kq_over_kt_m = cfg->vehicle.kq_over_kt_m;
    mp.differential = cfg->vehicle.mixer == CFG_MIXER_THROTTLE ? MIXER_DIFF_THROTTLE : MIXER_DIFF_THRUST;
    mp.hover_throttle = L->d_h;
    if (!mixer_init(&L->mixer, &mp))
        return fail(err, "vehicle", "no mixer for this frame");
    /* drivers */
    baro.supply_V = cfg->adc.baro.supply_V;
    baro.k_per_kPa = cfg->adc.baro.k_per_kPa;
    baro.offset_ratio = cfg->adc.baro.offset_ratio;
    baro.gain = cfg->adc.baro.gain;
    baro.offset_V = cfg->adc.baro.offset_V;
    baro.ref_V = cfg->adc.baro.ref_V;
    baro.zero_average_s = cfg->adc.baro.zero_average_s;
    baro.rail_margin_V = cfg->adc.baro.rail_margin_V;
    accel.supply_V = cfg->adc.accel.supply_V;
    accel.zero_g_ratio = cfg->adc.accel.zero_g_ratio;
    accel.sens_ratio_per_g = cfg->adc.accel.sens_ratio_per_g;
    if (!analog_parse_mount(mount, accel.mount_axis, accel.mount_sign))
        return fail(err, "adc.accel.mount_B", "not a signed permutation of X, Y, Z");
    analog_init(&L->analog, cfg->adc.vref_V, &baro, &accel);
    baro_ref_init(&L->baro_ref, cfg_ns(cfg->adc.baro.zero_average_s));
    accel_offset_init(&L->accel_zero);
    mcp3204_init(&L->adc, channels);
    xp.legacy = cfg->imu.identity == CFG_IMU_LEGACY;
    xp.rate_hz = (uint16_t)cfg->imu.rate_hz;
    xp.goto_config_attempts = (uint32_t)cfg->imu.goto_config_attempts;
    xp.reply_timeout_ns = (uint64_t)cfg_ns(cfg->imu.reply_timeout_s);
    xsens_init(&L->imu, &xp);
    if (cfg->rc.frontend == CFG_RC_CAPTURE) {
        ppm_params_t pp2;
        pp2.sync_min_us = (uint16_t)cfg->rc.capture.sync_min_us;
        pp2.pulse_min_us = (uint16_t)cfg->rc.capture.pulse_min_us;
        pp2.pulse_max_us = (uint16_t)cfg->rc.capture.pulse_max_us;
        pp2.min_channels = (uint8_t)cfg->rc.capture.min_channels;
        pp2.max_channels = (uint8_t)cfg->rc.capture.max_channels;
        pp2.lock_frames = (uint8_t)cfg->rc.capture.lock_frames;
        pp2.rising = cfg->rc.capture.rising;
        pp2.stale_ms = cfg->rc.capture.stale_ms;
        rc_init_capture(&L->rc, &pp2);
    } else {
        rc_init_sbus(&L->rc, cfg->rc.sbus.scale_us, cfg->rc.sbus.offset_us);
    }
    L->telemetry_on = cfg->telemetry.enable;
    xbee_link_init(&L->telemetry, cfg->telemetry.ap_mode == 2, (uint16_t)cfg->telemetry.dest16,
                   cfg->telemetry.request_status, (int32_t)cfg->telemetry.max_out_waiting);
    /* modes and landing */
    mo.gesture_throttle_max_us = cfg->modes.gesture_throttle_max_us;
    mo.arm_yaw_min_us = cfg->modes.arm_yaw_min_us;
    mo.disarm_yaw_max_us = cfg->modes.disarm_yaw_max_us;
    mo.gesture_hold_ns = cfg_ns(cfg->modes.gesture_hold_s);
    mo.landed_alt_m = cfg->modes.landed_alt_m;
    mo.landed_vz_mps = cfg->modes.landed_vz_mps;
    mo.landed_collective_ratio = cfg->modes.landed_collective_ratio;
    mo.landed_accel_mps2 = cfg->modes.landed_accel_mps2;
    mo.landed_ns = cfg_ns(cfg->modes.landed_s);
    mo.auto_disarm_ns = cfg_ns(cfg->modes.auto_disarm_s);
    mo.takeoff_alt_m = cfg->altitude.takeoff_alt_m;
    modes_init(&L->modes, &mo);
    if (!landing_descent_init(&L->descent, cfg->failsafe.descend_mps))
        return fail(err, "failsafe.descend_mps", "not a descent rate");
    if (!hover_throttle_init(&L->hover, L->d_h, HOVER_THROTTLE_TAU_S, 0.0f, 1.0f))
        return fail(err, "vehicle.m_kg", "no hover throttle for this mass and thrust");
    touchdown_accel_init(&L->a_up_lp);
    /* timing and sticks */
    L->rc_loss_ns = cfg_ns(cfg->failsafe.rc_loss_s);
    L->rest_after_ns = cfg_ns(cfg->kf.rest_after_s);
    L->tel_slot_ns = L->period_ns * cfg->telemetry.divider;
    L->stats_ns = cfg_ns(cfg->log.stats_period_s);
    L->ch[0] = (uint8_t)(cfg->rc.channel_roll - 1);
    L->ch[1] = (uint8_t)(cfg->rc.channel_pitch - 1);
    L->ch[2] = (uint8_t)(cfg->rc.channel_throttle - 1);
    L->ch[3] = (uint8_t)(cfg->rc.channel_yaw - 1);
    L->max_angle_rad = cfg->rc.max_angle_deg * DEG_F;
    L->max_yaw_rate_radps = cfg->rc.max_yaw_rate_dps * DEG_F;
    L->tel_last_slot = -1;
    L->last.z_baro_m = NAN;
    return true;
}

/* -- boot ------------------------------------------------------------------------------------ */

int loop_boot(flight_loop_t *L, hal_dev_t *failed, char *why, size_t why_len)
{
    xsens_info_t info;
    char id[12];
    int r;
    if (!xsens_bring_up(&L->imu, &info, why, why_len)) {
        *failed = HAL_DEV_IMU;
        return HAL_ERR_DEVICE;
    }
    r = hal_spi_start();
    if (r < 0) {
        *failed = HAL_DEV_ADC;
        snprintf(why, why_len, "%s", hal_last_error());
        return r;
    }
    loop_write_esc(L, NULL);
    if (log_begin(LOG_INFO, "esc.minimum")) {
        log_float("pulse_us", L->cfg->esc.min_us);
        log_end();
    }
    if (L->telemetry_on)
        xbee_link_drain(&L->telemetry);
    if (!xsens_start(&L->imu, why, why_len)) {
        *failed = HAL_DEV_IMU;
        return HAL_ERR_DEVICE;
    }
    snprintf(id, sizeof id, "%08lX", (unsigned long)info.device_id);
    if (log_begin(LOG_INFO, "boot.done")) {
        log_str("imu_device_id", id);
        log_str("rc_frontend", L->cfg->rc.frontend == CFG_RC_CAPTURE ? "capture" : "sbus");
        log_str("attitude_law", L->cfg->attitude.law == CFG_LAW_GENERALISED ? "generalised" : "paper_literal");
        log_str("accel_source", L->cfg->kf.accel_source == CFG_ACCEL_XSENS ? "xsens" : "adxl335");
        log_end();
    }
    return HAL_OK;
}

void loop_shutdown(flight_loop_t *L)
{
    loop_write_esc(L, NULL);
    if (log_begin(LOG_INFO, "shutdown")) {
        log_float("pulse_us", L->cfg->esc.min_us);
        log_end();
    }
}

/* -- services ------------------------------------------------------------------------------------ */

bool loop_rare(uint32_t *count)
{
    uint32_t n = ++*count;
    return (n & (n - 1)) == 0;
}

void loop_port_error(uint32_t *count, const char *device)
{
    char event[32];
    if (!loop_rare(count))
        return;
    snprintf(event, sizeof event, "%s.port_error", device);
    if (log_begin(LOG_ERROR, event)) {
        log_int("count", *count);
        log_str("error", hal_last_error());
        log_end();
    }
}

void loop_log_transitions(flight_loop_t *L)
{
    for (uint8_t i = 0; i < L->modes.n_transitions; i++) {
        const mode_transition_t *tr = &L->modes.transitions[i];
        if (log_begin(LOG_INFO, "mode")) {
            log_str("old", mode_name(tr->old_mode));
            log_str("new", mode_name(tr->new_mode));
            log_str("cause", mode_event_name(tr->event));
            log_end();
        }
    }
    L->modes.n_transitions = 0;
}

void loop_write_esc(flight_loop_t *L, const float *pulses_us)
{
    const fc_config_t *cfg = L->cfg;
    uint16_t qus[HAL_N_MOTORS];
    for (int i = 0; i < HAL_N_MOTORS; i++) {
        float p = pulses_us ? pulses_us[i] : cfg->esc.min_us;
        if (!(p >= cfg->esc.min_us)) /* NaN too: the safe side */
            p = cfg->esc.min_us;
        if (p > cfg->esc.max_us)
            p = cfg->esc.max_us;
        qus[i] = (uint16_t)lrintf(p * 4.0f);
        L->last.pulses_us[i] = p;
    }
    if (hal_esc_write(qus) < 0)
        loop_port_error(&L->counters.esc_port_errors, "esc");
}

static float unit(float pulse, float center, float half)
{
    float x = (pulse - center) / half;
    return x > 1.0f ? 1.0f : x < -1.0f ? -1.0f : x;
}

void loop_sticks(const flight_loop_t *L, const float *channels_us, float out[6])
{
    const fc_config_t *cfg = L->cfg;
    float roll_us = channels_us[L->ch[0]], pitch_us = channels_us[L->ch[1]];
    float thr_us = channels_us[L->ch[2]], yaw_us = channels_us[L->ch[3]];
    float range = cfg->altitude.alt_range_m;
    float z = range * (thr_us - cfg->rc.throttle_low_us) / cfg->rc.throttle_range_us;
    z = z > range ? range : z < 0.0f ? 0.0f : z;
    out[0] = unit(roll_us, cfg->rc.center_us, cfg->rc.half_range_us) * L->max_angle_rad;
    out[1] = unit(pitch_us, cfg->rc.center_us, cfg->rc.half_range_us) * L->max_angle_rad;
    out[2] = unit(yaw_us, cfg->rc.center_us, cfg->rc.half_range_us) * L->max_yaw_rate_radps;
    out[3] = z;
    out[4] = thr_us;
    out[5] = yaw_us;
}

void loop_fix_references(flight_loop_t *L)
{
    baro_reference_t *ref = &L->baro_ref;
    if (log_begin(LOG_INFO, "baro.reference")) {
        log_float("p_ref_Pa", ref->p_ref_Pa);
        log_int("samples", ref->n);
        log_end();
    }
    accel_offset_fix(&L->accel_zero);
    if (L->accel_zero.rejected) {
        if (log_begin(LOG_WARNING, "accel.offset_rejected")) {
            log_float("limit_mps2", L->accel_zero.limit_mps2);
            log_end();
        }
    } else if (log_begin(LOG_INFO, "accel.offset")) {
        log_float("x_mps2", L->accel_zero.offset_B_mps2[0]);
        log_float("y_mps2", L->accel_zero.offset_B_mps2[1]);
        log_float("z_mps2", L->accel_zero.offset_B_mps2[2]);
        log_end();
    }
    /* z = 0 is known to the accuracy of the average, not of one reading */
    altitude_kf_reset(&L->kf, 0.0f, L->cfg->kf.r_baro_m2 / (float)(ref->n ? ref->n : 1));
}

uint32_t loop_telemetry_dropped(const flight_loop_t *L)
{
    return L->telemetry.counters.dropped_busy + L->telemetry.counters.short_writes;
}

void loop_log_stats(flight_loop_t *L, fc_mode_t mode, float z_hat)
{
    const hal_counters_t *hc = hal_counters();
    if (log_begin(LOG_INFO, "stats")) {
        log_str("mode", mode_name(mode));
        log_float("z_hat_m", z_hat);
        log_float("compute_max_us", (double)L->stats_max_ns / 1000.0);
        log_int("imu_gaps", L->imu.counters.gap_samples);
        log_int("imu_skipped", L->imu.counters.skipped_samples);
        log_int("adc_failed", L->adc.counters.failed_reads);
        log_int("adc_resyncs", hc->adc_resyncs);
        log_int("adc_implausible", plausibility_refused(&L->plausible));
        log_int("baro_rejected", L->kf.counters.baro_rejected);
        if (L->baro_motion_on)
            log_float("baro_motion_worst_m", roundf(baro_motion_take_worst(&L->baro_motion) * 1000.0f) / 1000.0f);
        else
            log_str("baro_motion_worst_m", "off");
        log_int("baro_motion_refused", L->counters.baro_motion_refused);
        log_float("accel_offset_worst_mps2", roundf(plausibility_take_offset_worst(&L->plausible) * 1000.0f) / 1000.0f);
        log_float("hover_collective", L->hover.collective);
        log_int("rc_errors", rc_errors(&L->rc));
        log_int("telemetry_sent", L->telemetry_on ? L->telemetry.counters.sent : 0);
        log_end();
    }
    L->stats_max_ns = 0;
}
