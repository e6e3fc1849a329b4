/*
 * landing.h - the landing descent, the learnt hover collective, the touchdown accelerometer filter.
 *
 * The C twin of flightcode/control/landing.py and of the loop's low-pass on the XSENS's
 * vertical acceleration (flightcode/loop.py). A landing is flown as a descent at a fixed rate
 * that does not stop at the estimated ground level (near the ground the estimate is only as
 * good as a barometer in rotor wash): on the ground the altitude loop's integrator then winds
 * the collective down, and the touchdown test of the modes looks for the vehicle standing still
 * on a collective that could not hold it in the air. That test judges the collective against
 * the hover collective learnt in steady flight clear of the ground (hover_throttle_t), and the
 * measured vertical acceleration low-passed over 0.1 s (touchdown_accel_t).
 */
#ifndef FW_CONTROL_LANDING_H
#define FW_CONTROL_LANDING_H

#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

/* -- the descent ------------------------------------------------------------------------------ */

typedef struct {
    float rate_mps; /* failsafe.descend_mps, > 0 */
    float z_m;      /* setpoint, m (z up; goes below the take-off level until the landing is confirmed) */
    float z_lost_m; /* what the float32 sum has rounded away so far (compensated summation: the
                       same 1.25 mm step rounds the same way every sample, 5 mm over 28 m) */
    bool active;    /* between start and stop */
} landing_descent_t;

/* False if rate_mps is not finite and > 0. */
bool landing_descent_init(landing_descent_t *d, float rate_mps);

/* Begin the descent at z_m: the lower of the last setpoint and the estimate. */
void landing_descent_start(landing_descent_t *d, float z_m);

void landing_descent_stop(landing_descent_t *d);

/* Advance by dt_s of sensor time; returns the setpoint, m. */
float landing_descent_step(landing_descent_t *d, float dt_s);

/* -- the hover collective ------------------------------------------------------------------------ */

/* Averaging time constant of the hover collective, s of sensor time. */
#define HOVER_THROTTLE_TAU_S 2.0f
/* Steady flight: |vz| below this, m/s, and |vertical acceleration| below this, m/s^2. */
#define HOVER_THROTTLE_STEADY_VZ_MPS 0.3f
#define HOVER_THROTTLE_STEADY_AZ_MPS2 0.5f

typedef struct {
    float initial;    /* the model's sqrt(m g / F_max), until flight teaches better */
    float tau_s;
    float lo, hi;     /* the learnt value is kept within [lo, hi] */
    float collective; /* the estimate, unit throttle */
    float learnt_s;   /* sensor seconds of steady flight averaged so far */
} hover_throttle_t;

/* initial in (0, 1), tau_s > 0 (HOVER_THROTTLE_TAU_S; lo = 0, hi = 1 in the loop). */
bool hover_throttle_init(hover_throttle_t *h, float initial, float tau_s, float lo, float hi);

/* True when the estimate holds its height above clear_of_ground_m (ground effect below it
 * lowers the collective a hover needs): |vz| and |az| below the steady limits. */
bool hover_throttle_steady(float z_hat_m, float vz_hat_mps, float az_hat_mps2, float clear_of_ground_m);

/* Average one sample of steady flight (the caller decides what is steady); returns the estimate. */
float hover_throttle_update(hover_throttle_t *h, float collective, float dt_s);

/* -- the touchdown test's accelerometer ------------------------------------------------------- */

/* Time constant of the low-pass on the measured vertical acceleration, s (the XSENS's: long
 * enough to average vibration, short next to modes.landed_s). */
#define TOUCHDOWN_ACCEL_TAU_S 0.1f

typedef struct {
    float a_up_mps2; /* the low-passed vertical acceleration, m/s^2 up (starts at 0) */
} touchdown_accel_t;

void touchdown_accel_init(touchdown_accel_t *t);

/* One sample of the XSENS's vertical acceleration (non-finite: skipped); returns the filtered value. */
float touchdown_accel_update(touchdown_accel_t *t, float a_up_mps2, float dt_s);

#ifdef __cplusplus
}
#endif

#endif /* FW_CONTROL_LANDING_H */
