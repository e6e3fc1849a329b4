/*
 * plausibility.h - is a converted ADC reading one the sensors can produce?
 *
 * The C twin of flightcode/estimation/plausibility.py (docs/flightcode.md, loop step 2). The
 * Bus Pirate link checks its acks, and the MCP3204 driver its null bits and each code against
 * its LSB-first repeat (one bit flipped on the line); a flip of B0, the same bit flipped in both
 * copies, or a wrong value from the sensor or its analog chain still gives a valid-looking
 * code. A reading that fails here is treated as missing by the altitude filter (and counted):
 *
 *   barometer      within the MPX5100AP's 15-115 kPa; not a flat line (standard deviation over
 *                  the last baro_flat_readings below baro_flat_std_Pa: a live sensor moves by
 *                  its own noise, a stuck output does not); not more than baro_max_step_Pa from
 *                  the previous reading (accepted or not; the first reading, and the first after
 *                  a missing or out-of-range one, are judged on range and flat line only);
 *   accelerometer  every ADXL335 axis within accel_max_g (its supply rails); its vertical
 *                  acceleration within accel_xsens_tolerance_mps2 of the XSENS's, and its mean
 *                  too: the difference low-passed over accel_offset_tau_s within
 *                  accel_offset_max_mps2 (an offset that moved in flight; once beyond, back
 *                  within half of it). The loop then flies the altitude filter on the XSENS's
 *                  vertical acceleration (factory-calibrated over temperature).
 *
 * Pure functions of their inputs plus the previous pressure and the flat-line window.
 */
#ifndef FW_ESTIMATION_PLAUSIBILITY_H
#define FW_ESTIMATION_PLAUSIBILITY_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* MPX5100AP rated range, Pa (datasheet: 15 to 115 kPa). */
#define PLAUSIBILITY_BARO_MIN_PA 15000.0f
#define PLAUSIBILITY_BARO_MAX_PA 115000.0f
#define PLAUSIBILITY_G0_MPS2 9.80665f

/* Largest flat-line window, readings (RAM: 4 bytes each). The config's
 * plausibility.baro_flat_readings must not exceed it (plausibility_params_check). */
#define FLAT_LINE_MAX_READINGS 128u

typedef struct {
    float baro_max_step_Pa;          /* plausibility.baro_max_step_Pa */
    uint16_t baro_flat_readings;     /* plausibility.baro_flat_readings: 0 = off, else 2..FLAT_LINE_MAX_READINGS */
    float baro_flat_std_Pa;          /* plausibility.baro_flat_std_Pa */
    float accel_max_g;               /* plausibility.accel_max_g */
    float accel_xsens_tolerance_mps2; /* plausibility.accel_xsens_tolerance_mps2 */
    float accel_offset_tau_s;        /* plausibility.accel_offset_tau_s */
    float accel_offset_max_mps2;     /* plausibility.accel_offset_max_mps2 */
    float T_s;                       /* the loop's period, s (the mean check's low-pass step) */
} plausibility_params_t;

/*
 * Is a signal a flat line? The standard deviation of its last n values below min_std. O(1) a
 * value: running sums over a ring, taken relative to a reference value (no cancellation at
 * 1e5 Pa in single precision) and summed afresh at every turn of the ring (no drift: the sums
 * of the values that entered during a turn are kept beside, so a turn costs no pass), and
 * also when the sum of squares falls below FLAT_LINE_RESUM_RATIO of its peak since the last
 * fresh sum or the reference lies far from the window's mean (beyond 0.7 of the root mean
 * square deviation): an outlier (a flipped high bit, tens of kPa) leaving the window would
 * otherwise leave float32 rounding of its square (hundreds of Pa^2) as the window's variance.
 * The flightcode original runs in double precision and needs no such step.
 */
#define FLAT_LINE_RESUM_RATIO (1.0f / 64.0f)

typedef struct {
    float ring[FLAT_LINE_MAX_READINGS];
    uint16_t n;      /* window length */
    uint16_t i;      /* next slot */
    bool full;
    float ref;       /* the level the sums are taken relative to */
    float s1, s2;    /* sum of (v - ref), sum of (v - ref)^2 over the window */
    float s2_peak;   /* the largest s2 since the sums were last made afresh */
    float t1, t2;    /* the sums of the values that entered since the ring last turned */
    float min_var;   /* min_std^2 */
    bool flat;       /* the last verdict of flat_line_add (false until the window is full) */
} flat_line_t;

/* n in 2..FLAT_LINE_MAX_READINGS; returns false (and leaves fl unusable) otherwise. */
bool flat_line_init(flat_line_t *fl, uint16_t n, float min_std);

/* Take value x; true if the window (x and the n - 1 before it) is flat. */
bool flat_line_add(flat_line_t *fl, float x);

typedef struct {
    uint32_t baro_out_of_range;
    uint32_t baro_flat;
    uint32_t baro_step;
    uint32_t accel_out_of_range;
    uint32_t accel_disagrees_xsens;
    uint32_t accel_offset_moved;
} plausibility_counters_t;

typedef struct {
    plausibility_params_t p;
    float max_f_mps2;     /* accel_max_g x g0 */
    bool have_prev;       /* a previous reading to judge the step against */
    float p_prev_Pa;
    bool flat_on;         /* baro_flat_readings > 0 */
    flat_line_t flat;
    float offset_alpha;      /* T_s / (accel_offset_tau_s + T_s): no division a sample */
    float offset_mps2;       /* low-passed ADXL335 - XSENS vertical acceleration */
    float offset_worst_mps2; /* its largest size since plausibility_take_offset_worst */
    bool offset_moved;       /* the means disagree: the ADXL335's offset moved */
    plausibility_counters_t counters;
} plausibility_t;

/* false if the params are unusable (flat window of 1 or beyond FLAT_LINE_MAX_READINGS). */
bool plausibility_params_check(const plausibility_params_t *params);

/* Copy the params (checked: false if plausibility_params_check fails). */
bool plausibility_init(plausibility_t *pl, const plausibility_params_t *params);

/* Judge a pressure reading (present = false: no reading this sample). True if p_Pa is
 * believable and may be used; false if missing or refused (counted per reason). */
bool plausibility_baro_Pa(plausibility_t *pl, bool present, float p_Pa);

/* True while the barometer's readings are a flat line (refused). */
static inline bool plausibility_baro_flat(const plausibility_t *pl) { return pl->flat_on && pl->flat.flat; }

/* True if every axis of the ADXL335 specific force (m/s^2, before the offset correction) is
 * finite and within accel_max_g (counted if not). */
bool plausibility_accel_in_range(plausibility_t *pl, const float f_B_mps2[3]);

/* True if the ADXL335's vertical acceleration agrees with the XSENS's (counted if not). */
bool plausibility_accel_agrees(plausibility_t *pl, float a_up_mps2, float a_up_xsens_mps2);

/* True while the ADXL335's mean vertical acceleration agrees with the XSENS's (counted if not).
 * For readings plausibility_accel_agrees accepted; one low-pass step of T_s a reading. */
bool plausibility_accel_offset_holds(plausibility_t *pl, float a_up_mps2, float a_up_xsens_mps2);

/* The largest |low-passed difference| since the last call, m/s^2 (then reset). */
float plausibility_take_offset_worst(plausibility_t *pl);

/* Readings refused so far, all reasons. */
uint32_t plausibility_refused(const plausibility_t *pl);

#ifdef __cplusplus
}
#endif

#endif /* FW_ESTIMATION_PLAUSIBILITY_H */
