/* mixer.c - see mixer.h. */
#include "control/mixer.h"

#include <math.h>
#include <string.h>

static bool positive(float v)
{
    return isfinite(v) && v > 0.0f;
}

bool mixer_init(mixer_t *mx, const mixer_params_t *params)
{
    memset(mx, 0, sizeof *mx);
    mx->p = *params;
    const float a = params->arm_m;
    const float k = params->kq_over_kt_m;
    if (!positive(a) || !positive(params->F_max_motor_N) || !positive(k)) {
        return false;
    }
    if (!(params->hover_throttle > 0.0f && params->hover_throttle < 1.0f)) {
        return false;
    }
    float x[4], y[4];
    static const float spin[4] = {1.0f, 1.0f, -1.0f, -1.0f};
    if (params->frame == MIXER_FRAME_X) {
        const float l = a / sqrtf(2.0f);
        const float xs[4] = {l, -l, l, -l};
        const float ys[4] = {l, -l, -l, l};
        memcpy(x, xs, sizeof x);
        memcpy(y, ys, sizeof y);
    } else if (params->frame == MIXER_FRAME_PLUS) {
        const float xs[4] = {0.0f, 0.0f, a, -a};
        const float ys[4] = {a, -a, 0.0f, 0.0f};
        memcpy(x, xs, sizeof x);
        memcpy(y, ys, sizeof y);
    } else {
        return false;
    }
    if (params->differential == MIXER_DIFF_THROTTLE) {
        mx->per_hover = 1.0f / params->hover_throttle;
    } else if (params->differential == MIXER_DIFF_THRUST) {
        mx->per_hover = 0.0f;
    } else {
        return false;
    }
    /* The allocation's rows [1 1 1 1], -y, x, k spin are mutually orthogonal for both frames,
     * so its inverse's columns are those rows over their squared norms. */
    float n_roll = 0.0f, n_pitch = 0.0f, n_yaw = 0.0f;
    for (int i = 0; i < 4; i++) {
        mx->ny[i] = -y[i];
        mx->px[i] = x[i];
        mx->sz[i] = k * spin[i];
        n_roll += mx->ny[i] * mx->ny[i];
        n_pitch += mx->px[i] * mx->px[i];
        n_yaw += mx->sz[i] * mx->sz[i];
    }
    for (int i = 0; i < 4; i++) {
        mx->m_roll[i] = mx->ny[i] / n_roll;
        mx->m_pitch[i] = mx->px[i] / n_pitch;
        mx->m_yaw[i] = mx->sz[i] / n_yaw;
    }
    return true;
}

/* Largest beta in [0, 1] with 0 <= base_i + beta yaw_i <= F_max for all i (base fits). */
static float yaw_fraction(float fmax, const float base[4], const float yaw[4])
{
    float beta = 1.0f;
    for (int i = 0; i < 4; i++) {
        float room;
        if (yaw[i] > 0.0f) {
            room = (fmax - base[i]) / yaw[i];
        } else if (yaw[i] < 0.0f) {
            room = -base[i] / yaw[i];
        } else {
            continue;
        }
        if (room < beta) {
            beta = room;
        }
    }
    return beta > 0.0f ? beta : 0.0f;
}

static bool all_fit(const float f[4], float lo_ok, float hi_ok)
{
    for (int i = 0; i < 4; i++) {
        if (!(lo_ok <= f[i] && f[i] <= hi_ok)) {
            return false;
        }
    }
    return true;
}

void mixer_mix(mixer_t *mx, float collective_throttle, const float tau_Nm[3], mixer_out_t *out)
{
    const float fmax = mx->p.F_max_motor_N;
    float d_c = collective_throttle;
    if (!isfinite(d_c)) {
        mx->counters.nonfinite_collective++;
        d_c = 0.0f;
    }
    d_c = d_c > 1.0f ? 1.0f : (d_c < 0.0f ? 0.0f : d_c);
    float tx = tau_Nm[0], ty = tau_Nm[1], tz = tau_Nm[2];
    if (!(isfinite(tx) && isfinite(ty) && isfinite(tz))) {
        mx->counters.nonfinite_torque++;
        tx = isfinite(tx) ? tx : 0.0f;
        ty = isfinite(ty) ? ty : 0.0f;
        tz = isfinite(tz) ? tz : 0.0f;
    }
    const float gain = mx->per_hover == 0.0f ? 1.0f : d_c * mx->per_hover;
    const float rx = tx, ry = ty, rz = tz; /* the request, for the controllers when nothing can be applied */
    if (gain != 1.0f) {
        tx *= gain;
        ty *= gain;
        tz *= gain;
    }
    float f_c = fmax * d_c * d_c; /* collective per motor: 4 F_max d_c^2 / 4 */
    float rp[4], yw[4], thrust[4];
    for (int i = 0; i < 4; i++) {
        rp[i] = mx->m_roll[i] * tx + mx->m_pitch[i] * ty;
        yw[i] = mx->m_yaw[i] * tz;
        thrust[i] = (f_c + rp[i]) + yw[i];
    }
    float mag = 0.0f;
    for (int i = 0; i < 4; i++) {
        float m = fabsf(rp[i]) + fabsf(yw[i]);
        mag = m > mag ? m : mag;
    }
    float eps = MIXER_EPS_REL * (f_c + mag);
    eps = eps > MIXER_EPS_MIN_N ? eps : MIXER_EPS_MIN_N;
    const float lo_ok = -eps, hi_ok = fmax + eps;
    bool saturated = false;
    if (!all_fit(thrust, lo_ok, hi_ok)) {
        saturated = true;
        float base[4];
        for (int i = 0; i < 4; i++) {
            base[i] = f_c + rp[i];
        }
        if (!all_fit(base, lo_ok, hi_ok)) {
            /* roll/pitch alone do not fit: scale them if their spread is too wide, then shift
             * the collective the least that makes them fit */
            float lo = rp[0], hi = rp[0];
            for (int i = 1; i < 4; i++) {
                lo = rp[i] < lo ? rp[i] : lo;
                hi = rp[i] > hi ? rp[i] : hi;
            }
            float span = hi - lo;
            if (span > fmax) {
                float alpha = fmax / span;
                for (int i = 0; i < 4; i++) {
                    rp[i] *= alpha;
                }
                lo *= alpha;
                hi *= alpha;
            }
            float f_lo = f_c > -lo ? f_c : -lo;
            f_c = f_lo < fmax - hi ? f_lo : fmax - hi;
            for (int i = 0; i < 4; i++) {
                base[i] = f_c + rp[i];
            }
        }
        float beta = yaw_fraction(fmax, base, yw);
        for (int i = 0; i < 4; i++) {
            thrust[i] = base[i] + beta * yw[i];
        }
    }
    float f[4];
    for (int i = 0; i < 4; i++) {
        f[i] = thrust[i] > fmax ? fmax : (thrust[i] < 0.0f ? 0.0f : thrust[i]);
    }
    const float *ny = mx->ny, *px = mx->px, *sz = mx->sz;
    out->applied_tau_Nm[0] = ((ny[0] * f[0] + ny[1] * f[1]) + ny[2] * f[2]) + ny[3] * f[3];
    out->applied_tau_Nm[1] = ((px[0] * f[0] + px[1] * f[1]) + px[2] * f[2]) + px[3] * f[3];
    out->applied_tau_Nm[2] = ((sz[0] * f[0] + sz[1] * f[1]) + sz[2] * f[2]) + sz[3] * f[3];
    for (int j = 0; j < 3; j++) {
        if (gain == 1.0f) {
            out->applied_command_Nm[j] = out->applied_tau_Nm[j];
        } else if (gain > 0.0f) {
            out->applied_command_Nm[j] = out->applied_tau_Nm[j] / gain;
        }
    }
    if (!(gain > 0.0f)) { /* no differential at zero collective: the request is what the controllers hold */
        out->applied_command_Nm[0] = rx;
        out->applied_command_Nm[1] = ry;
        out->applied_command_Nm[2] = rz;
    }
    const float inv = 1.0f / fmax;
    for (int i = 0; i < 4; i++) {
        out->throttle[i] = sqrtf(f[i] * inv);
    }
    out->saturated = saturated;
    out->applied_collective_throttle = sqrtf((((f[0] + f[1]) + f[2]) + f[3]) * 0.25f * inv);
}
