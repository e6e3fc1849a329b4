/* plausibility.c - see plausibility.h. */
#include "estimation/plausibility.h"

#include <math.h>
#include <string.h>

bool flat_line_init(flat_line_t *fl, uint16_t n, float min_std)
{
    memset(fl, 0, sizeof *fl);
    if (n < 2u || n > FLAT_LINE_MAX_READINGS) {
        return false;
    }
    fl->n = n;
    fl->min_var = min_std * min_std;
    return true;
}

/* The sums afresh around the window's mean (the ring must be full), and the turn's sums of
 * the values that entered since the ring last turned (ring[0..i), all n when i is 0). */
static void flat_line_resum(flat_line_t *fl)
{
    const uint16_t n = fl->n;
    const uint16_t turn = fl->i == 0u ? n : fl->i;
    const float r0 = fl->ring[0];
    float dsum = 0.0f;
    for (uint16_t k = 0; k < n; k++) {
        dsum += fl->ring[k] - r0; /* differences of nearby values are exact: no rounding at 1e5 Pa */
    }
    fl->ref = r0 + dsum / (float)n;
    float s1 = 0.0f;
    float s2 = 0.0f;
    for (uint16_t k = 0; k < n; k++) {
        float d = fl->ring[k] - fl->ref;
        s1 += d;
        s2 += d * d;
        if (k + 1u == turn) {
            fl->t1 = s1;
            fl->t2 = s2;
        }
    }
    fl->s1 = s1;
    fl->s2 = s2;
    fl->s2_peak = s2;
}

bool flat_line_add(flat_line_t *fl, float x)
{
    const uint16_t n = fl->n;
    if (fl->i == 0u && fl->full) {
        /* a turn of the ring: the window is the values that entered during the last turn,
         * whose sums were kept as they came (each added once, never taken back): sums afresh
         * with no drift over a flight, without a pass over the ring in this reading's time */
        fl->s1 = fl->t1;
        fl->s2 = fl->t2;
        fl->s2_peak = fl->t2;
        fl->t1 = 0.0f;
        fl->t2 = 0.0f;
    } else if (fl->i == 0u) {
        fl->ref = x;
    }
    float d_old = fl->ring[fl->i] - fl->ref;
    float d = x - fl->ref;
    if (fl->full) {
        fl->s1 -= d_old;
        fl->s2 -= d_old * d_old;
    }
    fl->s1 += d;
    fl->s2 += d * d;
    fl->t1 += d;
    fl->t2 += d * d;
    fl->ring[fl->i] = x;
    fl->i++;
    if (fl->i == n) {
        fl->i = 0;
        fl->full = true;
    }
    if (!fl->full) {
        fl->flat = false;
        return false;
    }
    if (fl->s2 > fl->s2_peak) {
        fl->s2_peak = fl->s2;
    }
    float mean = fl->s1 / (float)n;
    if (fl->s2 < fl->s2_peak * FLAT_LINE_RESUM_RATIO || mean * mean > 0.5f * (fl->s2 / (float)n)) {
        /* float32 keeps 24 bits: after an outlier left the window what remains of s2 is the
         * rounding of its square; a reference far from the window's mean (an outlier was in
         * the window when it was taken) leaves the variance as a difference of two large
         * numbers */
        flat_line_resum(fl);
        mean = fl->s1 / (float)n;
    }
    fl->flat = fl->s2 / (float)n - mean * mean < fl->min_var;
    return fl->flat;
}

bool plausibility_params_check(const plausibility_params_t *params)
{
    uint16_t n = params->baro_flat_readings;
    return n == 0u || (n >= 2u && n <= FLAT_LINE_MAX_READINGS);
}

bool plausibility_init(plausibility_t *pl, const plausibility_params_t *params)
{
    memset(pl, 0, sizeof *pl);
    if (!plausibility_params_check(params)) {
        return false;
    }
    pl->p = *params;
    pl->max_f_mps2 = params->accel_max_g * PLAUSIBILITY_G0_MPS2;
    pl->offset_alpha = params->T_s / (params->accel_offset_tau_s + params->T_s);
    pl->flat_on = params->baro_flat_readings > 0u;
    if (pl->flat_on) {
        (void)flat_line_init(&pl->flat, params->baro_flat_readings, params->baro_flat_std_Pa);
    }
    return true;
}

bool plausibility_baro_Pa(plausibility_t *pl, bool present, float p_Pa)
{
    if (!present) {
        pl->have_prev = false;
        return false;
    }
    bool had_prev = pl->have_prev;
    float prev = pl->p_prev_Pa;
    pl->have_prev = true;
    pl->p_prev_Pa = p_Pa;
    if (!(PLAUSIBILITY_BARO_MIN_PA <= p_Pa && p_Pa <= PLAUSIBILITY_BARO_MAX_PA)) {
        pl->counters.baro_out_of_range++;
        pl->have_prev = false; /* not a level to compare the next one with */
        return false;
    }
    if (pl->flat_on && flat_line_add(&pl->flat, p_Pa)) {
        pl->counters.baro_flat++;
        return false;
    }
    if (had_prev && fabsf(p_Pa - prev) > pl->p.baro_max_step_Pa) {
        pl->counters.baro_step++;
        return false;
    }
    return true;
}

bool plausibility_accel_in_range(plausibility_t *pl, const float f_B_mps2[3])
{
    const float m = pl->max_f_mps2;
    for (int i = 0; i < 3; i++) {
        float f = f_B_mps2[i];
        /* a NaN fails both compares; an infinity fails one */
        if (!(-m <= f && f <= m)) {
            pl->counters.accel_out_of_range++;
            return false;
        }
    }
    return true;
}

bool plausibility_accel_agrees(plausibility_t *pl, float a_up_mps2, float a_up_xsens_mps2)
{
    if (fabsf(a_up_mps2 - a_up_xsens_mps2) <= pl->p.accel_xsens_tolerance_mps2) {
        return true;
    }
    pl->counters.accel_disagrees_xsens++;
    return false;
}

bool plausibility_accel_offset_holds(plausibility_t *pl, float a_up_mps2, float a_up_xsens_mps2)
{
    const float max = pl->p.accel_offset_max_mps2;
    pl->offset_mps2 += pl->offset_alpha * (a_up_mps2 - a_up_xsens_mps2 - pl->offset_mps2);
    float size = fabsf(pl->offset_mps2);
    if (size > pl->offset_worst_mps2) {
        pl->offset_worst_mps2 = size;
    }
    /* once beyond, it must come back within half the limit: no flicker at the edge */
    pl->offset_moved = size > (pl->offset_moved ? 0.5f * max : max);
    if (pl->offset_moved) {
        pl->counters.accel_offset_moved++;
    }
    return !pl->offset_moved;
}

float plausibility_take_offset_worst(plausibility_t *pl)
{
    float worst = pl->offset_worst_mps2;
    pl->offset_worst_mps2 = 0.0f;
    return worst;
}

uint32_t plausibility_refused(const plausibility_t *pl)
{
    const plausibility_counters_t *c = &pl->counters;
    return c->baro_out_of_range + c->baro_flat + c->baro_step + c->accel_out_of_range + c->accel_disagrees_xsens +
           c->accel_offset_moved;
}
