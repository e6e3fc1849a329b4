/* lqi_altitude.c - see lqi_altitude.h. */
#include "control/lqi_altitude.h"

#include <math.h>
#include <string.h>

float lqi_altitude_hover_throttle(float m_kg, float F_max_N)
{
    return sqrtf(m_kg * LQI_G_MPS2 / F_max_N);
}

bool lqi_altitude_params_make(lqi_altitude_params_t *params, const lqi_altitude_gains_t *gains, float T_s,
                              float m_kg, float F_max_N)
{
    memset(params, 0, sizeof *params);
    if (!(isfinite(T_s) && T_s > 0.0f && isfinite(m_kg) && m_kg > 0.0f && isfinite(F_max_N)
          && m_kg * LQI_G_MPS2 < F_max_N)) {
        return false;
    }
    params->gains = *gains;
    params->T_s = T_s;
    params->d_h = lqi_altitude_hover_throttle(m_kg, F_max_N);
    params->u_min = -params->d_h;
    params->u_max = 1.0f - params->d_h;
    return isfinite(gains->f_z) && isfinite(gains->f_vz) && isfinite(gains->f_az) && isfinite(gains->f_r);
}

void lqi_altitude_init(lqi_altitude_t *c, const lqi_altitude_params_t *params)
{
    memset(c, 0, sizeof *c);
    c->p = *params;
}

void lqi_altitude_reset(lqi_altitude_t *c)
{
    c->x_r_m_s = 0.0f;
    c->last_u = 0.0f;
}

float lqi_altitude_update(lqi_altitude_t *c, float z_ref_m, float z_hat_m, float vz_hat_mps, float az_hat_mps2,
                          bool active)
{
    const lqi_altitude_params_t *p = &c->p;
    const lqi_altitude_gains_t *k = &p->gains;
    if (!active) {
        lqi_altitude_reset(c);
        return 0.0f;
    }
    float err = z_ref_m - z_hat_m;
    float u = -((k->f_z * z_hat_m + k->f_vz * vz_hat_mps) + k->f_az * az_hat_mps2) - k->f_r * c->x_r_m_s;
    if (!(isfinite(u) && isfinite(err))) {
        c->counters.nonfinite_input++;
        return p->d_h + c->last_u;
    }
    /* this sample's integration moves u by -f_r err x T */
    float push = -k->f_r * err;
    bool integrate;
    if (u > p->u_max) {
        u = p->u_max;
        integrate = push < 0.0f;
    } else if (u < p->u_min) {
        u = p->u_min;
        integrate = push > 0.0f;
    } else {
        integrate = true;
    }
    if (integrate) {
        c->x_r_m_s += p->T_s * err;
    }
    float d = p->d_h + u;
    d = d > 1.0f ? 1.0f : (d < 0.0f ? 0.0f : d);
    c->last_u = d - p->d_h;
    return d;
}
