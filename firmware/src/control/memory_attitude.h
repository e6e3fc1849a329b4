/*
 * memory_attitude.h - memory-based (time-delay-estimation) roll/pitch controller, one axis.
 *
 * The C twin of flightcode/control/memory_attitude.py (docs/controllers.md 2.1, Eq. 3.24
 * corrected, with the generalised weights):
 *
 *     e   = phi - phi*                       rad (phi: measured Euler angle)
 *     s   = e' + k0 e                        rad/s (e' from the gyro Euler rate, never d/dt phi)
 *     eta = phi*'' + tau_ff phi*''' - k0 e'  rad/s^2 (0 for the Eq. 3.25 form)
 *     u_k = sat( u_{k-1} + J (w1 s_k + w2 s_{k-1}) + J (eta_k - eta_{k-1}) )    N m
 *
 * with w1 = (p1 + p2 - 2)/T and w2 = (1 - p1 p2)/T for s-poles p_i = exp(-omega_i T). The
 * paper's literal weights (w1 = -2/T, w2 = 1/T, no eta) stay selectable only so the bench can
 * show its control-activity criterion catching the chatter they cause at 400 Hz.
 *
 * Anti-windup is the paper's: u_{k-1} holds the torque actually applied, after the torque
 * limit here and after the mixer's clipping (memory_attitude_set_applied).
 */
#ifndef FW_CONTROL_MEMORY_ATTITUDE_H
#define FW_CONTROL_MEMORY_ATTITUDE_H

#include <stdbool.h>
#include <stdint.h>

#include "control/reference.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    float T_s;          /* loop period, s */
    float k0_per_s;     /* sliding-surface slope, 1/s */
    float J_hat_kgm2;   /* inertia estimate (u in N m), kg m^2 */
    float w1_per_s;     /* memory weights, 1/s */
    float w2_per_s;
    float tau_ff_s;     /* actuator-lag lead in eta, s */
    float u_limit_Nm;   /* symmetric torque limit, N m */
    bool use_eta;       /* true: Eq. 3.24 (eta feed-forward); false: Eq. 3.25 */
} memory_attitude_gains_t;

/* attitude.law = "generalised": s-poles exp(-omega_i T), eta feed-forward with the lead.
 * False if a value is unusable (T, J, limit not > 0; anything non-finite). */
bool memory_attitude_gains_from_poles(memory_attitude_gains_t *g, float T_s, float omega1_radps,
                                      float omega2_radps, float k0_per_s, float J_hat_kgm2, float tau_ff_s,
                                      float u_limit_Nm);

/* attitude.law = "paper_literal": w1 = -2/T, w2 = 1/T, no eta, no lead (demonstration only). */
bool memory_attitude_gains_paper_literal(memory_attitude_gains_t *g, float T_s, float k0_per_s,
                                         float J_hat_kgm2, float u_limit_Nm);

typedef struct {
    uint32_t nonfinite_input;   /* non-finite s or eta: the output is held */
    uint32_t nonfinite_applied; /* non-finite applied torque: ignored */
} memory_attitude_counters_t;

typedef struct {
    memory_attitude_gains_t g;
    float u_prev_Nm;     /* u_{k-1}: requested, or the applied value given to set_applied */
    float s_prev_radps;  /* s_{k-1} */
    float eta_prev_radps2;
    float s_radps;       /* s of the last update */
    bool primed;         /* false: the next active update starts with s_{k-1} = s_k */
    memory_attitude_counters_t counters;
} memory_attitude_t;

void memory_attitude_init(memory_attitude_t *c, const memory_attitude_gains_t *gains);

/* Forget the memory: the next active update starts with u_{k-1} = 0, s_{k-1} = s_k. */
void memory_attitude_reset(memory_attitude_t *c);

/*
 * Torque request about this body axis (FRD), N m, within +-u_limit_Nm.
 *   ref         reference angle and derivatives (prefilter3)
 *   angle_rad   measured Euler angle
 *   rate_radps  its rate from the gyro (roll: p + (q sin phi + r cos phi) tan theta;
 *               pitch: q cos phi - r sin phi)
 *   active      false while disarmed, landed or at idle: the memory is not updated
 *               (u_{k-1} = 0, s_{k-1} = s, eta_{k-1} = eta) and 0 is returned
 */
float memory_attitude_update(memory_attitude_t *c, const ref_state_t *ref, float angle_rad, float rate_radps,
                             bool active);

/* Store the torque actually applied (after mixer clipping) as u_{k-1}, N m. */
void memory_attitude_set_applied(memory_attitude_t *c, float torque_Nm);

#ifdef __cplusplus
}
#endif

#endif /* FW_CONTROL_MEMORY_ATTITUDE_H */
