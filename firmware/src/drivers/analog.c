/* Analog chains: see analog.h. */
#include "drivers/analog.h"

#include <math.h>
#include <string.h>

#define ISA_P0_PA 101325.0f
#define ISA_H_SCALE_M 44330.769f /* T0 / L = 288.15 K / 0.0065 K/m */
#define ISA_EXPONENT 0.190263f   /* R* L / (g0 M) */

bool analog_parse_mount(const char *const entries[3], uint8_t axis[3], int8_t sign[3])
{
    unsigned seen = 0;
    for (int i = 0; i < 3; i++) {
        const char *e = entries[i];
        char c;
        if (!e || strlen(e) != 2 || (e[0] != '+' && e[0] != '-'))
            return false;
        c = e[1];
        if (c >= 'a' && c <= 'z')
            c = (char)(c - 'a' + 'A');
        if (c < 'X' || c > 'Z')
            return false;
        axis[i] = (uint8_t)(c - 'X');
        sign[i] = e[0] == '+' ? 1 : -1;
        seen |= 1u << axis[i];
    }
    return seen == 7u;
}

float isa_altitude_m(float p_Pa) { return ISA_H_SCALE_M * (1.0f - powf(p_Pa / ISA_P0_PA, ISA_EXPONENT)); }

void analog_init(analog_chain_t *a, float vref_V, const baro_chain_params_t *baro, const accel_chain_params_t *accel)
{
    int margin;
    a->vref_V = vref_V;
    a->baro = *baro;
    a->accel = *accel;
    a->v_per_code = vref_V / ANALOG_RESOLUTION_CODES;
    margin = (int)ceilf(baro->rail_margin_V / a->v_per_code);
    if (margin < 0)
        margin = 0;
    a->rail_lo_code = margin;
    a->rail_hi_code = ANALOG_RESOLUTION_CODES - 1 - margin;
    a->acc_zero_V = accel->supply_V * accel->zero_g_ratio;
    a->acc_mps2_per_V = G0_MPS2 / (accel->supply_V * accel->sens_ratio_per_g);
}

float analog_volts(const analog_chain_t *a, int code) { return ((float)code + 0.5f) * a->v_per_code; }

bool analog_baro_Pa(const analog_chain_t *a, int code, float *p_Pa)
{
    const baro_chain_params_t *b = &a->baro;
    float v_sensor;
    if (code <= a->rail_lo_code || code >= a->rail_hi_code)
        return false;
    v_sensor = (analog_volts(a, code) - b->ref_V) / b->gain + b->offset_V;
    *p_Pa = (v_sensor / b->supply_V + b->offset_ratio) / b->k_per_kPa * 1000.0f;
    return true;
}

void analog_accel_B(const analog_chain_t *a, int code_x, int code_y, int code_z, float f_B[3])
{
    float s[3];
    s[0] = (analog_volts(a, code_x) - a->acc_zero_V) * a->acc_mps2_per_V;
    s[1] = (analog_volts(a, code_y) - a->acc_zero_V) * a->acc_mps2_per_V;
    s[2] = (analog_volts(a, code_z) - a->acc_zero_V) * a->acc_mps2_per_V;
    for (int i = 0; i < 3; i++)
        f_B[i] = (float)a->accel.mount_sign[i] * s[a->accel.mount_axis[i]];
}

void accel_offset_init(accel_rest_offset_t *o)
{
    memset(o, 0, sizeof *o);
    o->limit_mps2 = 1.5f * G0_MPS2;
}

void accel_offset_add(accel_rest_offset_t *o, const float f_B[3], float roll_rad, float pitch_rad)
{
    float sphi = sinf(roll_rad), cphi = cosf(roll_rad);
    float sth = sinf(pitch_rad), cth = cosf(pitch_rad);
    o->sum[0] += (double)(f_B[0] - G0_MPS2 * sth);
    o->sum[1] += (double)(f_B[1] + G0_MPS2 * sphi * cth);
    o->sum[2] += (double)(f_B[2] + G0_MPS2 * cphi * cth);
    o->n++;
}

void accel_offset_fix(accel_rest_offset_t *o)
{
    float mean[3], worst = 0.0f;
    if (!o->n)
        return;
    for (int i = 0; i < 3; i++) {
        mean[i] = (float)(o->sum[i] / o->n);
        if (fabsf(mean[i]) > worst)
            worst = fabsf(mean[i]);
    }
    if (worst > o->limit_mps2)
        o->rejected = true;
    else
        memcpy(o->offset_B_mps2, mean, sizeof mean);
}

void accel_offset_correct(const accel_rest_offset_t *o, float f_B[3])
{
    for (int i = 0; i < 3; i++)
        f_B[i] -= o->offset_B_mps2[i];
}

void baro_ref_init(baro_reference_t *r, int64_t average_ns)
{
    memset(r, 0, sizeof *r);
    r->average_ns = average_ns;
}

bool baro_ref_add(baro_reference_t *r, float p_Pa, int64_t t_ns)
{
    if (r->ready)
        return true;
    if (!r->started) {
        r->started = true;
        r->t_first_ns = t_ns;
    }
    r->sum += (double)p_Pa;
    r->n++;
    if (t_ns - r->t_first_ns >= r->average_ns) {
        r->p_ref_Pa = (float)(r->sum / r->n);
        r->h_ref_m = isa_altitude_m(r->p_ref_Pa);
        r->ready = true;
    }
    return r->ready;
}

float baro_ref_altitude_m(const baro_reference_t *r, float p_Pa) { return isa_altitude_m(p_Pa) - r->h_ref_m; }
