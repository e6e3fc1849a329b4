/*
 * The 400 Hz loop: one iteration per IMU sample, everything timed on sensor time, as
 * flightcode/loop.py and loop_parts.py (docs/flightcode.md "The loop"):
 *
 *  1. block on the next IMU sample (the read timeout is the IMU-loss watchdog: motors to
 *     minimum, FAILSAFE_IMU);
 *  2. read the four ADC channels; readings the sensors cannot produce are dropped;
 *  3. take the RC input (non-blocking);
 *  4. estimate altitude (the filter predicted with the throttle applied over the last sample,
 *     updated with the gated barometer, checked against the accelerometers' motion, and the
 *     tilt-compensated vertical acceleration);
 *  5. modes; a landing is flown as a descent that does not stop at the estimated ground;
 *  6. control: stick prefilters, memory attitude (roll, pitch), PI yaw rate, LQI altitude;
 *  7. mix and write one ESC command;
 *  8. telemetry every telemetry.divider-th sample slot of sensor time.
 *
 * Compute time is hal_now_ns around the iteration minus the two blocking exchanges (IMU wait,
 * ADC transaction). A device that misbehaves in flight is counted and logged; the loop keeps
 * flying on what it has or fails safe, it never stops.
 */
#ifndef FW_LOOP_H
#define FW_LOOP_H

#include <stdbool.h>
#include <stdint.h>

#include "config.h"
#include "control/landing.h"
#include "control/lqi_altitude.h"
#include "control/memory_attitude.h"
#include "control/mixer.h"
#include "control/reference.h"
#include "control/yaw_rate.h"
#include "drivers/analog.h"
#include "drivers/mcp3204.h"
#include "drivers/rc.h"
#include "drivers/xbee.h"
#include "drivers/xsens.h"
#include "estimation/altitude_kf.h"
#include "estimation/baro_motion.h"
#include "estimation/plausibility.h"
#include "hal.h"
#include "modes.h"
#include "telemetry.h"

/* The variance of the inertial vertical velocity the estimate is moved to when the
 * barometer's motion disagrees, (m/s)^2: twice the estimator's own at the window's start. */
#define BARO_MOTION_VZ_VAR 0.04f

typedef struct {
    uint32_t imu_timeouts, imu_port_errors, adc_port_errors, rc_port_errors, esc_port_errors, telemetry_port_errors;
    uint32_t baro_out_of_range, baro_in_ground_effect, baro_motion_refused, adc_implausible, baro_rejected_logged;
} loop_counters_t;

/* What the last iteration did (tests and the stats line read it). */
typedef struct {
    fc_mode_t mode;
    float z_ref_m, z_hat_m, z_baro_m; /* z_baro_m NaN: no reading */
    bool rc_valid, adc_valid;
    float pulses_us[4];
    uint64_t compute_ns;
} loop_last_t;

typedef struct {
    const fc_config_t *cfg;
    /* drivers */
    xsens_t imu;
    mcp3204_t adc;
    rc_input_t rc;
    xbee_link_t telemetry;
    bool telemetry_on;
    analog_chain_t analog;
    baro_reference_t baro_ref;
    accel_rest_offset_t accel_zero;
    /* estimation and control */
    plausibility_t plausible;
    baro_motion_t baro_motion;
    bool baro_motion_on;
    altitude_kf_t kf;
    prefilter3_t roll_pf, pitch_pf;
    memory_attitude_t roll_ctl, pitch_ctl;
    yaw_rate_t yaw_ctl;
    lqi_altitude_t lqi;
    mixer_t mixer;
    landing_descent_t descent;
    hover_throttle_t hover;
    touchdown_accel_t a_up_lp;
    modes_t modes;
    float d_h;
    /* timing */
    int64_t period_ns, rc_loss_ns, rest_after_ns, tel_slot_ns, stats_ns;
    /* stick map */
    uint8_t ch[4];
    float max_angle_rad, max_yaw_rate_radps;
    /* state carried between samples */
    bool have_t_prev;
    int64_t t_prev_ns;
    float u_applied;            /* throttle deviation applied over the last sample (KF input) */
    float collective_applied;   /* collective applied over the last sample (touchdown test) */
    float z_ref_m;
    bool rest_anchored;
    int64_t rest_anchored_ns;   /* the rest period whose start was handled */
    uint32_t tel_seq;
    int64_t tel_last_slot;
    int64_t stats_next_ns;
    uint64_t stats_max_ns;
    bool skipped_in_window;
    compute_window_t window;
    loop_counters_t counters;
    loop_last_t last;
} flight_loop_t;

/* Build every part from cfg (kept by pointer): false with err naming the key when the config
 * cannot be flown by this build (a design input differs from the generated header's). */
bool loop_init(flight_loop_t *L, const fc_config_t *cfg, cfg_error_t *err);

/* Bring every device up: HAL_OK, or < 0 with *failed and why naming the device's problem. */
int loop_boot(flight_loop_t *L, hal_dev_t *failed, char *why, size_t why_len);

/* One iteration: wait for a sample and process it, or handle the watchdog. */
void loop_step(flight_loop_t *L);

/* Process one IMU sample (steps 2-8). */
void loop_tick(flight_loop_t *L, const imu_sample_t *sample);

/* Motors to minimum (a stop request, any exit path). */
void loop_shutdown(flight_loop_t *L);

#endif
