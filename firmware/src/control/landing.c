/* landing.c - see landing.h. */
#include "control/landing.h"

#include <math.h>

bool landing_descent_init(landing_descent_t *d, float rate_mps)
{
    d->rate_mps = rate_mps;
    d->z_m = 0.0f;
    d->z_lost_m = 0.0f;
    d->active = false;
    return isfinite(rate_mps) && rate_mps > 0.0f;
}

void landing_descent_start(landing_descent_t *d, float z_m)
{
    d->z_m = z_m;
    d->z_lost_m = 0.0f;
    d->active = true;
}

void landing_descent_stop(landing_descent_t *d)
{
    d->active = false;
}

float landing_descent_step(landing_descent_t *d, float dt_s)
{
    float step = -d->rate_mps * dt_s - d->z_lost_m;
    float z = d->z_m + step;
    d->z_lost_m = (z - d->z_m) - step;
    d->z_m = z;
    return z;
}

bool hover_throttle_init(hover_throttle_t *h, float initial, float tau_s, float lo, float hi)
{
    h->initial = initial;
    h->tau_s = tau_s;
    h->lo = lo;
    h->hi = hi;
    h->collective = initial;
    h->learnt_s = 0.0f;
    return initial > 0.0f && initial < 1.0f && isfinite(tau_s) && tau_s > 0.0f;
}

bool hover_throttle_steady(float z_hat_m, float vz_hat_mps, float az_hat_mps2, float clear_of_ground_m)
{
    return z_hat_m > clear_of_ground_m && fabsf(vz_hat_mps) < HOVER_THROTTLE_STEADY_VZ_MPS
           && fabsf(az_hat_mps2) < HOVER_THROTTLE_STEADY_AZ_MPS2;
}

float hover_throttle_update(hover_throttle_t *h, float collective, float dt_s)
{
    if (isfinite(collective) && dt_s > 0.0f) {
        float alpha = dt_s / (h->tau_s + dt_s);
        float c = h->collective + alpha * (collective - h->collective);
        c = c > h->lo ? c : h->lo;
        h->collective = c < h->hi ? c : h->hi;
        h->learnt_s += dt_s;
    }
    return h->collective;
}

void touchdown_accel_init(touchdown_accel_t *t)
{
    t->a_up_mps2 = 0.0f;
}

float touchdown_accel_update(touchdown_accel_t *t, float a_up_mps2, float dt_s)
{
    if (isfinite(a_up_mps2)) {
        t->a_up_mps2 += dt_s / (TOUCHDOWN_ACCEL_TAU_S + dt_s) * (a_up_mps2 - t->a_up_mps2);
    }
    return t->a_up_mps2;
}
