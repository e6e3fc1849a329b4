/*
 * altitude_kf.h - altitude Kalman filter: barometer + vertical accelerometer + thrust model.
 *
 * The C twin of flightcode/estimation/altitude_kf.py (docs/controllers.md 3.5). States, z up:
 *
 *     x = [z m, z' m/s, a m/s^2, d m/s^2, b m/s^2]
 *     z'' = a + d;  a' = (-a + (k/m) u) / T1 + w_a;  d' = w_d;  b' = w_b
 *     y   = [z_baro, a_up] = [z, a + d + b] + noise
 *
 * a: thrust-deviation acceleration driven by u = d_throttle - d_h; d: slow disturbance
 * (payload, ground effect); b: accelerometer bias. The discrete model (F, B by zero-order hold,
 * Q by Van Loan) is designed once by firmware/gen from the flight config, with the Python
 * flight code's own design functions (fc_design.h, FC_DESIGN_KF_MODEL).
 *
 * Per sample the caller runs altitude_kf_predict() with the throttle deviation applied over the
 * last sample, then altitude_kf_update() with this sample's readings. The barometer reading is
 * gated: innovation^2 > baro_gate_chi2 x (P_zz + R) is rejected (an outlier); rejections in a
 * row lasting baro_gate_max_rejects samples re-anchor the height to the reading. R is diagonal,
 * so the two measurements are applied one scalar at a time (exactly the joint update), each a
 * rank-one covariance update without a matrix inverse. P is kept exactly symmetric: only its
 * upper triangle is computed and mirrored (flightcode computes all of it and re-symmetrises
 * every predict), and F P F^T skips F's zero entries.
 *
 * Single precision throughout. The state struct is the caller's; nothing is allocated.
 */
#ifndef FW_ESTIMATION_ALTITUDE_KF_H
#define FW_ESTIMATION_ALTITUDE_KF_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define ALTITUDE_KF_N 5

/* The discrete model for one loop period T_s (generated: fc_design.h). */
typedef struct {
    float F[ALTITUDE_KF_N][ALTITUDE_KF_N]; /* state transition */
    float B[ALTITUDE_KF_N];                /* input column, per unit throttle deviation */
    float Q[ALTITUDE_KF_N][ALTITUDE_KF_N]; /* process noise covariance, symmetric */
} altitude_kf_model_t;

/* Everything the filter needs (the model by pointer: it lives in flash). */
typedef struct {
    const altitude_kf_model_t *model;
    float r_baro_m2;          /* barometric altitude noise variance, m^2 (kf.r_baro_m2) */
    float r_acc_m2ps4;        /* vertical acceleration noise variance, (m/s^2)^2 (kf.r_acc) */
    float r_rest_vz_m2ps2;    /* zero-velocity pseudo-measurement variance, (m/s)^2 (kf.r_rest_vz) */
    float baro_gate_chi2;     /* gate: reject innovation^2 > this x S (kf.baro_gate_chi2, > 0) */
    uint32_t baro_gate_max_rejects; /* rejections in a row that re-anchor the height:
                                       max(1, round(kf.baro_gate_timeout_s / T_s)) */
} altitude_kf_params_t;

typedef struct {
    uint32_t nonfinite_input;  /* non-finite throttle deviation (taken as 0) */
    uint32_t nonfinite_baro;   /* non-finite barometer reading (taken as missing) */
    uint32_t nonfinite_acc;    /* non-finite acceleration (taken as missing) */
    uint32_t baro_rejected;    /* barometer readings rejected by the gate */
    uint32_t baro_reanchored;  /* re-anchors after a lasting disagreement */
} altitude_kf_counters_t;

typedef struct {
    altitude_kf_params_t p;
    float x[ALTITUDE_KF_N];                 /* [z m, z' m/s, a m/s^2, d m/s^2, b m/s^2] */
    float P[ALTITUDE_KF_N][ALTITUDE_KF_N];  /* covariance, symmetric (after predict: the prior) */
    /* F's non-zero entries, row by row (found at init): the products skip its zeros (15 of
     * 25 for the altitude model) and multiply by none of its ones (4): on a soft-float ARM7
     * those multiplications were two thirds of a predict's time */
    uint8_t f_nnz;
    uint8_t f_row[ALTITUDE_KF_N * ALTITUDE_KF_N];
    uint8_t f_col[ALTITUDE_KF_N * ALTITUDE_KF_N];
    bool f_unit[ALTITUDE_KF_N * ALTITUDE_KF_N];  /* the entry is exactly 1: no multiplication */
    uint32_t baro_reject_run;               /* barometer readings rejected in a row */
    altitude_kf_counters_t counters;
} altitude_kf_t;

/* Initial variances of [z, z', a, d, b] after a reset, except z's (the caller's, or one
 * barometer reading's): the vehicle at rest, a payload/thrust mismatch of ~1 m/s^2, an ADXL335
 * zero-g offset of ~0.5 m/s^2. */
#define ALTITUDE_KF_P0_VZ 0.01f
#define ALTITUDE_KF_P0_A 0.01f
#define ALTITUDE_KF_P0_D 1.0f
#define ALTITUDE_KF_P0_B 0.25f

/* kf.baro_gate_timeout_s in samples: max(1, round(timeout / period)), half to even as Python's
 * round(); both in ns (round(s x 1e9)), so a timeout of 4.5 samples is 4 as in the Python
 * flight code, not the 5 its single-precision quotient would give. */
uint32_t altitude_kf_gate_max_rejects(int64_t timeout_ns, int64_t period_ns);

/* Copy the params and reset at z = 0 with one barometer reading's variance. */
void altitude_kf_init(altitude_kf_t *kf, const altitude_kf_params_t *params);

/* Restart at z0_m (m, up), at rest, with the initial covariance and P_zz = z_var_m2 (m^2). */
void altitude_kf_reset(altitude_kf_t *kf, float z0_m, float z_var_m2);

/* Propagate one sample with the applied throttle deviation u = d - d_h (unit throttle). */
void altitude_kf_predict(altitude_kf_t *kf, float u_throttle_dev);

/*
 * Correct with this sample's readings. baro_valid / acc_valid false: no reading (a non-finite
 * value with its flag set is counted and skipped). baro_r_scale: this reading's variance is
 * r_baro_m2 x this (> 1: trusted less). Returns false if a barometer reading was given and the
 * gate rejected it, else true. Barometer first, then acceleration (the Python order).
 */
bool altitude_kf_update(altitude_kf_t *kf, bool baro_valid, float z_baro_m, bool acc_valid, float a_up_mps2,
                        float baro_r_scale);

/* The vehicle stands on the ground: fuse z' = 0 with variance r_rest_vz. */
void altitude_kf_update_at_rest(altitude_kf_t *kf);

/* The height as uncertain as z_var_m2 (m^2), uncorrelated with the rest: the next barometer
 * readings re-anchor it (after a touchdown the accelerometer may have missed). */
void altitude_kf_loosen_height(altitude_kf_t *kf, float z_var_m2);

/* Put the height at z_m and the climb at vz_mps with these variances, the disturbance d back
 * to 0 with its initial variance, all three uncorrelated with the rest (the inertial height of
 * the barometer-motion check when the barometer turns out not to measure the vehicle). */
void altitude_kf_move_to(altitude_kf_t *kf, float z_m, float vz_mps, float z_var_m2, float vz_var_m2);

static inline float altitude_kf_z_m(const altitude_kf_t *kf) { return kf->x[0]; }
static inline float altitude_kf_vz_mps(const altitude_kf_t *kf) { return kf->x[1]; }
/* estimated vertical acceleration a + d, m/s^2 (what the LQI uses as z'') */
static inline float altitude_kf_az_mps2(const altitude_kf_t *kf) { return kf->x[2] + kf->x[3]; }

#ifdef __cplusplus
}
#endif

#endif /* FW_ESTIMATION_ALTITUDE_KF_H */
