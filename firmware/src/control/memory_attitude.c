/* memory_attitude.c - see memory_attitude.h. */
#include "control/memory_attitude.h"

#include <math.h>
#include <string.h>

static bool positive(float v)
{
    return isfinite(v) && v > 0.0f;
}

static bool gains_ok(const memory_attitude_gains_t *g)
{
    return positive(g->T_s) && positive(g->J_hat_kgm2) && positive(g->u_limit_Nm) && isfinite(g->k0_per_s)
           && isfinite(g->w1_per_s) && isfinite(g->w2_per_s) && isfinite(g->tau_ff_s);
}

bool memory_attitude_gains_from_poles(memory_attitude_gains_t *g, float T_s, float omega1_radps,
                                      float omega2_radps, float k0_per_s, float J_hat_kgm2, float tau_ff_s,
                                      float u_limit_Nm)
{
    memset(g, 0, sizeof *g);
    if (!positive(T_s) || !isfinite(omega1_radps) || !isfinite(omega2_radps)) {
        return false;
    }
    /* p_i - 1 by expm1f: w1 = ((p1 - 1) + (p2 - 1)) / T and w2 = (1 - p1 p2) / T are small
     * differences of numbers near 1, which plain expf would leave with 1e-5 relative error */
    float p1_m1 = expm1f(-omega1_radps * T_s);
    float p2_m1 = expm1f(-omega2_radps * T_s);
    g->T_s = T_s;
    g->k0_per_s = k0_per_s;
    g->J_hat_kgm2 = J_hat_kgm2;
    g->w1_per_s = (p1_m1 + p2_m1) / T_s;
    g->w2_per_s = -expm1f(-(omega1_radps + omega2_radps) * T_s) / T_s;
    g->tau_ff_s = tau_ff_s;
    g->u_limit_Nm = u_limit_Nm;
    g->use_eta = true;
    return gains_ok(g);
}

bool memory_attitude_gains_paper_literal(memory_attitude_gains_t *g, float T_s, float k0_per_s,
                                         float J_hat_kgm2, float u_limit_Nm)
{
    memset(g, 0, sizeof *g);
    if (!positive(T_s)) {
        return false;
    }
    g->T_s = T_s;
    g->k0_per_s = k0_per_s;
    g->J_hat_kgm2 = J_hat_kgm2;
    g->w1_per_s = -2.0f / T_s;
    g->w2_per_s = 1.0f / T_s;
    g->tau_ff_s = 0.0f;
    g->u_limit_Nm = u_limit_Nm;
    g->use_eta = false;
    return gains_ok(g);
}

void memory_attitude_init(memory_attitude_t *c, const memory_attitude_gains_t *gains)
{
    memset(c, 0, sizeof *c);
    c->g = *gains;
}

void memory_attitude_reset(memory_attitude_t *c)
{
    c->u_prev_Nm = 0.0f;
    c->s_prev_radps = 0.0f;
    c->eta_prev_radps2 = 0.0f;
    c->s_radps = 0.0f;
    c->primed = false;
}

static float clamp_sym(float u, float lim)
{
    return u > lim ? lim : (u < -lim ? -lim : u);
}

float memory_attitude_update(memory_attitude_t *c, const ref_state_t *ref, float angle_rad, float rate_radps,
                             bool active)
{
    const memory_attitude_gains_t *g = &c->g;
    const float k0 = g->k0_per_s;
    float ed = rate_radps - ref->rate_radps;
    float s = ed + k0 * (angle_rad - ref->angle_rad);
    float eta = g->use_eta ? (ref->acc_radps2 + g->tau_ff_s * ref->jerk_radps3) - k0 * ed : 0.0f;
    if (!(isfinite(s) && isfinite(eta))) {
        /* a NaN must never enter the memory: hold the last output */
        c->counters.nonfinite_input++;
        return active ? c->u_prev_Nm : 0.0f;
    }
    c->s_radps = s;
    if (!active || !c->primed) {
        c->s_prev_radps = s;
        c->eta_prev_radps2 = eta;
        c->primed = true;
        if (!active) {
            c->u_prev_Nm = 0.0f;
            return 0.0f;
        }
    }
    const float j = g->J_hat_kgm2;
    float u = (c->u_prev_Nm + j * (g->w1_per_s * s + g->w2_per_s * c->s_prev_radps))
              + j * (eta - c->eta_prev_radps2);
    u = clamp_sym(u, g->u_limit_Nm);
    c->u_prev_Nm = u;
    c->s_prev_radps = s;
    c->eta_prev_radps2 = eta;
    return u;
}

void memory_attitude_set_applied(memory_attitude_t *c, float torque_Nm)
{
    if (!isfinite(torque_Nm)) {
        c->counters.nonfinite_applied++;
        return;
    }
    c->u_prev_Nm = clamp_sym(torque_Nm, c->g.u_limit_Nm);
}
