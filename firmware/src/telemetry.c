/* Telemetry payload: see telemetry.h. */
#include "telemetry.h"

#include <math.h>
#include <string.h>

static uint8_t *put_u16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    return p + 2;
}

static uint8_t *put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
    return p + 4;
}

static uint8_t *put_f32(uint8_t *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return put_u32(p, u);
}

/* Non-negative count or duration to u16: NaN -> 0, saturating at 65535, rounded. */
static uint16_t sat_u16(float v)
{
    if (!(v > 0.0f))
        return 0;
    if (v >= 65535.0f)
        return 65535;
    return (uint16_t)lrintf(v);
}

void telemetry_encode(const telemetry_record_t *rec, uint8_t out[TELEMETRY_PAYLOAD_LEN])
{
    uint8_t *p = out;
    *p++ = TELEMETRY_VERSION;
    *p++ = rec->mode;
    p = put_u16(p, rec->seq & 0xFFFFu);
    p = put_u32(p, (uint32_t)((uint64_t)(rec->t_ns / 100000) & 0xFFFFFFFFu));
    p = put_u16(p, rec->flags);
    for (int i = 0; i < 3; i++)
        p = put_f32(p, rec->euler_rad[i]);
    p = put_f32(p, rec->z_hat_m);
    p = put_f32(p, rec->vz_hat_mps);
    p = put_f32(p, rec->z_baro_m);
    p = put_f32(p, rec->roll_ref_rad);
    p = put_f32(p, rec->pitch_ref_rad);
    p = put_f32(p, rec->yaw_rate_ref_radps);
    p = put_f32(p, rec->z_ref_m);
    for (int i = 0; i < 4; i++)
        p = put_u16(p, sat_u16(rec->pulses_us[i] * 4.0f));
    p = put_f32(p, rec->collective);
    for (int i = 0; i < 3; i++)
        p = put_f32(p, rec->tau_applied_Nm[i]);
    p = put_u16(p, sat_u16(rec->compute_last_us));
    p = put_u16(p, sat_u16(rec->compute_max_us));
    p = put_u16(p, sat_u16(rec->compute_mean_us));
    p = put_u16(p, rec->imu_gap_samples);
    p = put_u16(p, rec->imu_skipped_samples);
    p = put_u16(p, rec->adc_failed_reads);
    p = put_u16(p, rec->rc_errors);
    put_u16(p, rec->telemetry_dropped);
}

void compute_window_add(compute_window_t *w, uint64_t compute_ns)
{
    w->last_ns = compute_ns;
    if (compute_ns > w->max_ns)
        w->max_ns = compute_ns;
    w->sum_ns += compute_ns;
    w->n++;
}

void compute_window_take(compute_window_t *w, float *last_us, float *max_us, float *mean_us)
{
    *last_us = (float)w->last_ns / 1000.0f;
    *max_us = (float)w->max_ns / 1000.0f;
    *mean_us = w->n ? (float)((double)w->sum_ns / w->n) / 1000.0f : 0.0f;
    w->max_ns = w->sum_ns = 0;
    w->n = 0;
}
