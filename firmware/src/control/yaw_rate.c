/* yaw_rate.c - see yaw_rate.h. */
#include "control/yaw_rate.h"

#include <math.h>
#include <string.h>

bool yaw_rate_init(yaw_rate_t *c, const yaw_rate_params_t *params)
{
    memset(c, 0, sizeof *c);
    c->p = *params;
    c->ki_T = params->ki_Nm_per_rad * params->T_s;
    return isfinite(params->kp_Nm_per_radps) && params->kp_Nm_per_radps >= 0.0f && isfinite(params->ki_Nm_per_rad)
           && params->ki_Nm_per_rad >= 0.0f && isfinite(params->u_limit_Nm) && params->u_limit_Nm > 0.0f
           && isfinite(params->T_s) && params->T_s > 0.0f;
}

void yaw_rate_reset(yaw_rate_t *c)
{
    c->i_Nm = 0.0f;
    c->u_req_Nm = 0.0f;
}

float yaw_rate_update(yaw_rate_t *c, float rate_ref_radps, float rate_meas_radps, bool active)
{
    if (!active) {
        yaw_rate_reset(c);
        return 0.0f;
    }
    float e = rate_ref_radps - rate_meas_radps;
    if (!isfinite(e)) {
        c->counters.nonfinite_input++;
        return c->u_req_Nm;
    }
    const float lim = c->p.u_limit_Nm;
    float u = c->p.kp_Nm_per_radps * e + c->i_Nm;
    bool windup;
    if (u >= lim) {
        u = lim;
        windup = e > 0.0f;
    } else if (u <= -lim) {
        u = -lim;
        windup = e < 0.0f;
    } else {
        windup = false;
    }
    if (!windup) {
        float i = c->i_Nm + c->ki_T * e;
        c->i_Nm = i > lim ? lim : (i < -lim ? -lim : i);
    }
    c->u_req_Nm = u;
    return u;
}

void yaw_rate_set_applied(yaw_rate_t *c, float torque_Nm)
{
    if (!isfinite(torque_Nm)) {
        c->counters.nonfinite_applied++;
        return;
    }
    float shortfall = c->u_req_Nm - torque_Nm;
    /* only unwind: shrink |i| toward zero when the clip opposes the integral's sign */
    if (c->i_Nm != 0.0f && shortfall != 0.0f && (c->i_Nm > 0.0f) == (shortfall > 0.0f)) {
        float i = c->i_Nm - shortfall;
        if (c->i_Nm > 0.0f) {
            c->i_Nm = i > 0.0f ? i : 0.0f;
        } else {
            c->i_Nm = i < 0.0f ? i : 0.0f;
        }
    }
    c->u_req_Nm = torque_Nm;
}
