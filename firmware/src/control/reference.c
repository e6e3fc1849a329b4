/* reference.c - see reference.h. */
#include "control/reference.h"

#include <math.h>
#include <string.h>

/* 1 - e^-h (1 + h + h^2/2), the step response of (s+w)^-3 w^3 after h = w T, without the
 * cancellation of the direct form at small h: e^-h x sum_{k>=3} h^k / k!. */
static float step_response_3(float h, float e)
{
    if (h > 0.5f) {
        return 1.0f - e * (1.0f + h + 0.5f * h * h);
    }
    float term = h * h * h / 6.0f;
    float sum = 0.0f;
    for (int k = 4; k < 20 && term > 1e-12f * sum; k++) {
        sum += term;
        term *= h / (float)k;
    }
    return e * sum;
}

bool prefilter3_params_make(prefilter3_params_t *params, float omega_radps, float T_s)
{
    memset(params, 0, sizeof *params);
    if (!(isfinite(omega_radps) && omega_radps > 0.0f && isfinite(T_s) && T_s > 0.0f)) {
        return false;
    }
    const float w = omega_radps;
    const float h = w * T_s;
    const float e = expf(-h);
    /* exp(A T) of the companion matrix of (s + w)^3: each entry e^-h times a polynomial */
    params->a[0][0] = e * (1.0f + h + 0.5f * h * h);
    params->a[0][1] = e * T_s * (1.0f + h);
    params->a[0][2] = e * 0.5f * T_s * T_s;
    params->a[1][0] = -e * 0.5f * w * h * h;
    params->a[1][1] = e * (1.0f + h - h * h);
    params->a[1][2] = e * T_s * (1.0f - 0.5f * h);
    params->a[2][0] = e * w * w * h * (0.5f * h - 1.0f);
    params->a[2][1] = e * w * h * (h - 3.0f);
    params->a[2][2] = e * (1.0f - 2.0f * h + 0.5f * h * h);
    /* the integral of exp(A t) b over the period, b = [0, 0, w^3] */
    params->b[0] = step_response_3(h, e);
    params->b[1] = e * 0.5f * w * h * h;
    params->b[2] = e * w * w * h * (1.0f - 0.5f * h);
    params->w3 = w * w * w;
    params->c1 = 3.0f * w * w;
    params->c2 = 3.0f * w;
    return true;
}

void prefilter3_init(prefilter3_t *pf, const prefilter3_params_t *params)
{
    pf->p = *params;
    (void)prefilter3_reset(pf, 0.0f);
}

ref_state_t prefilter3_reset(prefilter3_t *pf, float value)
{
    pf->y = value;
    pf->yd = 0.0f;
    pf->ydd = 0.0f;
    pf->cmd = value;
    ref_state_t out = {value, 0.0f, 0.0f, 0.0f};
    return out;
}

ref_state_t prefilter3_update(prefilter3_t *pf, float cmd)
{
    const prefilter3_params_t *p = &pf->p;
    if (!isfinite(cmd)) {
        cmd = pf->cmd;
    }
    pf->cmd = cmd;
    float y = pf->y, yd = pf->yd, ydd = pf->ydd;
    pf->y = ((p->a[0][0] * y + p->a[0][1] * yd) + p->a[0][2] * ydd) + p->b[0] * cmd;
    pf->yd = ((p->a[1][0] * y + p->a[1][1] * yd) + p->a[1][2] * ydd) + p->b[1] * cmd;
    pf->ydd = ((p->a[2][0] * y + p->a[2][1] * yd) + p->a[2][2] * ydd) + p->b[2] * cmd;
    ref_state_t out;
    out.angle_rad = pf->y;
    out.rate_radps = pf->yd;
    out.acc_radps2 = pf->ydd;
    out.jerk_radps3 = (p->w3 * (cmd - pf->y) - p->c1 * pf->yd) - p->c2 * pf->ydd;
    return out;
}
