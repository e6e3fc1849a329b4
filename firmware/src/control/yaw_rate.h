/*
 * yaw_rate.h - PI yaw-rate controller (the paper controls roll/pitch angles; yaw by rate).
 *
 * The C twin of flightcode/control/yaw_rate.py:
 *
 *     e = r* - r              rad/s (r: body yaw rate from the gyro, positive nose right)
 *     u = sat(kp e + i)       N m about the FRD z axis
 *     i <- i + ki T e         conditional integration: frozen while u saturates in the
 *                             direction of e; i itself bounded by the limit
 *
 * The mixer cuts yaw first when it must: pass the torque it really applied to
 * yaw_rate_set_applied so the integrator unwinds (never past zero).
 */
#ifndef FW_CONTROL_YAW_RATE_H
#define FW_CONTROL_YAW_RATE_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    float kp_Nm_per_radps; /* yaw.kp_Nm_per_radps, >= 0 */
    float ki_Nm_per_rad;   /* yaw.ki_Nm_per_rad, >= 0 */
    float u_limit_Nm;      /* yaw.u_limit_Nm, > 0 */
    float T_s;             /* loop period, s */
} yaw_rate_params_t;

typedef struct {
    uint32_t nonfinite_input;   /* non-finite rate error: the output is held */
    uint32_t nonfinite_applied; /* non-finite applied torque: ignored */
} yaw_rate_counters_t;

typedef struct {
    yaw_rate_params_t p;
    float ki_T;          /* ki x T, N m per (rad/s) per sample */
    float i_Nm;          /* integral term */
    float u_req_Nm;      /* the last request (then the last applied torque) */
    yaw_rate_counters_t counters;
} yaw_rate_t;

/* False if a gain is negative or non-finite, or the limit or period not > 0. */
bool yaw_rate_init(yaw_rate_t *c, const yaw_rate_params_t *params);

/* Clear the integrator. */
void yaw_rate_reset(yaw_rate_t *c);

/* Yaw torque request, N m (FRD z, positive nose right); 0 and the integrator cleared if not active. */
float yaw_rate_update(yaw_rate_t *c, float rate_ref_radps, float rate_meas_radps, bool active);

/* The yaw torque the mixer really produced, N m: a clipped request moves the integrator back
 * by the shortfall, never past zero. */
void yaw_rate_set_applied(yaw_rate_t *c, float torque_Nm);

#ifdef __cplusplus
}
#endif

#endif /* FW_CONTROL_YAW_RATE_H */
