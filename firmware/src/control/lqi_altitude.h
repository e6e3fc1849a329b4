/*
 * lqi_altitude.h - LQI altitude controller (Wang/Ma/Sun Eqs. 4.4-4.14, docs/controllers.md 3.1-3.3).
 *
 * The C twin of flightcode/control/lqi_altitude.py. Model (z up): thrust F = F_max d^2
 * linearised at the hover throttle d_h = sqrt(m g / F_max), first-order thrust lag T1; input
 * u = d - d_h. The integral x_r' = r - z augments it and the continuous LQR gives
 *
 *     u = -(f_z z + f_vz z' + f_az z'') - f_r x_r
 *
 * The gains are designed once from the flight config by firmware/gen, with the Python flight
 * code's design function (fc_design.h, FC_DESIGN_LQI_GAINS); the loop emulates them at 400 Hz
 * with x_r integrated by forward Euler. Anti-windup by conditional integration: x_r is not
 * integrated on a sample whose output saturates in the direction the error would push it.
 */
#ifndef FW_CONTROL_LQI_ALTITUDE_H
#define FW_CONTROL_LQI_ALTITUDE_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Standard gravity, m/s^2. */
#define LQI_G_MPS2 9.80665f

/* The LQI gains (generated): per m, s/m, s^2/m and 1/(m s). */
typedef struct {
    float f_z;
    float f_vz;
    float f_az;
    float f_r;
} lqi_altitude_gains_t;

typedef struct {
    lqi_altitude_gains_t gains;
    float T_s;     /* loop period, s */
    float d_h;     /* hover throttle sqrt(m g / F_max), unit throttle */
    float u_min;   /* throttle deviation limits: -d_h and 1 - d_h (collective in [0, 1]) */
    float u_max;
} lqi_altitude_params_t;

/* Hover throttle sqrt(m g / F_max) of the model (0.724 for the paper's quad). */
float lqi_altitude_hover_throttle(float m_kg, float F_max_N);

/* Params for the gains at period T_s for a vehicle of m_kg and F_max_N (the collective kept in
 * [0, 1]); false if the vehicle cannot hover or a value is unusable. */
bool lqi_altitude_params_make(lqi_altitude_params_t *params, const lqi_altitude_gains_t *gains, float T_s,
                              float m_kg, float F_max_N);

typedef struct {
    uint32_t nonfinite_input; /* non-finite estimate or setpoint: the output is held */
} lqi_altitude_counters_t;

typedef struct {
    lqi_altitude_params_t p;
    float x_r_m_s;   /* integral of (z_ref - z_hat), m s */
    float last_u;    /* the applied throttle deviation (the altitude filter's input) */
    lqi_altitude_counters_t counters;
} lqi_altitude_t;

void lqi_altitude_init(lqi_altitude_t *c, const lqi_altitude_params_t *params);

/* Clear the integrator and the last output. */
void lqi_altitude_reset(lqi_altitude_t *c);

/* Collective throttle in [0, 1] = d_h + u (z up; estimates from the altitude filter). Not
 * active: the integrator is cleared, last_u = 0 and 0 is returned (the modes decide what the
 * motors do on the ground). */
float lqi_altitude_update(lqi_altitude_t *c, float z_ref_m, float z_hat_m, float vz_hat_mps, float az_hat_mps2,
                          bool active);

#ifdef __cplusplus
}
#endif

#endif /* FW_CONTROL_LQI_ALTITUDE_H */
