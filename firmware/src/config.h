/*
 * The flight code's own configuration: the same TOML file and keys as flightcode/
 * (docs/flightcode.md documents every key; defaults = the paper's vehicle). Only [ports] is
 * required; any other table or key may be left out. Unknown tables or keys, wrong types and
 * out-of-range values are errors naming the file, the dotted key and the reason:
 *
 *     vehicle.toml: attitude.law: must be one of 'generalised', 'paper_literal' (got 'fast')
 *
 * The posix build reads the file named on its command line; the lpc2148 build parses the same
 * text compiled into the image (firmware/Makefile, FLIGHT_CONFIG). One parser, one set of checks.
 */
#ifndef FW_CONFIG_H
#define FW_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <math.h>

#ifdef FW_EMBEDDED_CONFIG
#define CFG_PATH_MAX 48 /* the board has no file system: paths and file names are short labels */
#else
#define CFG_PATH_MAX 256
#endif

typedef struct {
    bool present;
    char path[CFG_PATH_MAX];
    int64_t baud;
} cfg_port_t;

typedef enum { CFG_IMU_MK4 = 0, CFG_IMU_LEGACY = 1 } cfg_imu_identity_t;
typedef enum { CFG_RC_CAPTURE = 0, CFG_RC_SBUS = 1 } cfg_rc_frontend_t;
typedef enum { CFG_FRAME_X = 0, CFG_FRAME_PLUS = 1 } cfg_frame_t;
typedef enum { CFG_MIXER_THROTTLE = 0, CFG_MIXER_THRUST = 1 } cfg_mixer_t;
typedef enum { CFG_LAW_GENERALISED = 0, CFG_LAW_PAPER_LITERAL = 1 } cfg_law_t;
typedef enum { CFG_ACCEL_ADXL335 = 0, CFG_ACCEL_XSENS = 1 } cfg_accel_source_t;

typedef struct {
    struct { cfg_port_t imu, adc, rc, esc, telemetry; } ports;
    struct {
        int identity; /* cfg_imu_identity_t */
        int64_t rate_hz, goto_config_attempts;
        float reply_timeout_s;
    } imu;
    struct {
        int64_t spi_speed_hz, baro_channel, accel_channels[3], entry_attempts;
        float vref_V, read_timeout_s, reply_timeout_s, quiet_s, resync_interval_s;
        struct {
            float supply_V, k_per_kPa, offset_ratio, gain, offset_V, ref_V, zero_average_s, rail_margin_V;
        } baro;
        struct {
            float supply_V, zero_g_ratio, sens_ratio_per_g;
            char mount_B[3][4];
        } accel;
    } adc;
    struct {
        int frontend; /* cfg_rc_frontend_t */
        int64_t channel_roll, channel_pitch, channel_throttle, channel_yaw;
        float center_us, half_range_us, throttle_low_us, throttle_range_us, max_angle_deg, max_yaw_rate_dps;
        struct {
            int64_t sync_min_us, pulse_min_us, pulse_max_us, min_channels, max_channels, lock_frames;
            bool rising;
            float stale_ms;
        } capture;
        struct { float scale_us, offset_us; } sbus;
    } rc;
    struct {
        float min_us, max_us, idle_us;
        int64_t first_channel;
    } esc;
    struct {
        int frame; /* cfg_frame_t */
        float arm_m, F_max_N, kq_over_kt_m, m_kg;
        int mixer; /* cfg_mixer_t */
    } vehicle;
    struct {
        int law; /* cfg_law_t */
        float omega1_radps, omega2_radps, k0_per_s, J_hat_kgm2, tau_ff_s, u_limit_Nm, prefilter_omega_radps;
    } attitude;
    struct { float kp_Nm_per_radps, ki_Nm_per_rad, u_limit_Nm; } yaw;
    struct { float T1_s, q_int, q_z, q_vz, q_az, r, alt_range_m, takeoff_alt_m; } altitude;
    struct {
        int accel_source; /* cfg_accel_source_t */
        float q_a, q_d, q_b, r_baro_m2, r_acc, r_rest_vz, rest_after_s, ground_effect_alt_m, ground_effect_r_scale;
        float baro_gate_chi2, baro_gate_timeout_s;
    } kf;
    struct {
        float baro_max_step_Pa, baro_flat_std_Pa, accel_max_g, accel_xsens_tolerance_mps2;
        float accel_offset_tau_s, accel_offset_max_mps2;
        int64_t baro_flat_readings;
        float baro_motion_window_s, baro_motion_block_s, baro_motion_max_m;
    } plausibility;
    struct { float rc_loss_s, descend_mps, imu_timeout_s; } failsafe;
    struct {
        bool enable, request_status;
        int64_t ap_mode, dest16, divider, max_out_waiting;
    } telemetry;
    struct {
        float gesture_throttle_max_us, arm_yaw_min_us, disarm_yaw_max_us, gesture_hold_s, landed_alt_m, landed_vz_mps;
        float landed_collective_ratio, landed_accel_mps2, landed_s, auto_disarm_s;
    } modes;
    struct {
        int level; /* log_level_t */
        float stats_period_s;
    } log;
} fc_config_t;

typedef struct {
    char file[CFG_PATH_MAX];
    char key[96];
    char reason[256];
} cfg_error_t;

/* Every default (the paper's vehicle); ports absent. */
void cfg_defaults(fc_config_t *cfg);

/* Parse and check the TOML text (file names it in errors): true, or false with *err. */
bool cfg_parse(const char *text, size_t len, const char *file, fc_config_t *cfg, cfg_error_t *err);

/* "file: key: reason" */
void cfg_error_format(const cfg_error_t *err, char *out, size_t cap);

/* A config duration (float32 seconds) in ns, rounded to the microsecond first: 0.1f is
 * 0.100000001 s, and the ns it would give puts a 0.1 s timer one sample late on the 2.5 ms
 * grid where flightcode's float64 value lands on it. Config durations have <= 6 decimals. */
static inline int64_t cfg_ns(float s) { return (int64_t)llround((double)s * 1e6) * 1000; }

/* Loop period = IMU sample period, s. */
static inline float cfg_T_s(const fc_config_t *cfg) { return 1.0f / (float)cfg->imu.rate_hz; }

#endif
