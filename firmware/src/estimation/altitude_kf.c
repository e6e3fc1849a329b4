/* altitude_kf.c - see altitude_kf.h. */
#include "estimation/altitude_kf.h"

#include <math.h>
#include <string.h>

#define N ALTITUDE_KF_N

uint32_t altitude_kf_gate_max_rejects(int64_t timeout_ns, int64_t period_ns)
{
    if (timeout_ns <= 0 || period_ns <= 0) {
        return 1u;
    }
    int64_t q = timeout_ns / period_ns;
    int64_t r2 = 2 * (timeout_ns % period_ns);
    if (r2 > period_ns || (r2 == period_ns && (q & 1) != 0)) {
        q++;
    }
    if (q > (int64_t)UINT32_MAX) {
        return UINT32_MAX;
    }
    return q >= 1 ? (uint32_t)q : 1u;
}

void altitude_kf_init(altitude_kf_t *kf, const altitude_kf_params_t *params)
{
    memset(kf, 0, sizeof *kf);
    kf->p = *params;
    for (uint8_t i = 0; i < N; i++) {
        for (uint8_t k = 0; k < N; k++) {
            if (params->model->F[i][k] != 0.0f) {
                kf->f_row[kf->f_nnz] = i;
                kf->f_col[kf->f_nnz] = k;
                kf->f_unit[kf->f_nnz] = params->model->F[i][k] == 1.0f;
                kf->f_nnz++;
            }
        }
    }
    altitude_kf_reset(kf, 0.0f, params->r_baro_m2);
}

void altitude_kf_reset(altitude_kf_t *kf, float z0_m, float z_var_m2)
{
    static const float p0_rest[N] = {0.0f, ALTITUDE_KF_P0_VZ, ALTITUDE_KF_P0_A, ALTITUDE_KF_P0_D, ALTITUDE_KF_P0_B};
    memset(kf->x, 0, sizeof kf->x);
    memset(kf->P, 0, sizeof kf->P);
    kf->x[0] = z0_m;
    for (int i = 1; i < N; i++) {
        kf->P[i][i] = p0_rest[i];
    }
    kf->P[0][0] = z_var_m2;
    kf->baro_reject_run = 0;
}

void altitude_kf_predict(altitude_kf_t *kf, float u_throttle_dev)
{
    const altitude_kf_model_t *m = kf->p.model;
    float xn[N] = {0.0f};
    float fp[N][N] = {{0.0f}};
    if (!isfinite(u_throttle_dev)) {
        kf->counters.nonfinite_input++;
        u_throttle_dev = 0.0f;
    }
    /* x = F x + B u and FP = F P, over F's non-zero entries (row by row, as a dense product
     * sums them: the same result) */
    for (uint8_t e = 0; e < kf->f_nnz; e++) {
        const uint8_t i = kf->f_row[e], k = kf->f_col[e];
        const float f = m->F[i][k];
        if (kf->f_unit[e]) {
            xn[i] += kf->x[k];
            for (int j = 0; j < N; j++) {
                fp[i][j] += kf->P[k][j];
            }
        } else {
            xn[i] += f * kf->x[k];
            for (int j = 0; j < N; j++) {
                fp[i][j] += f * kf->P[k][j];
            }
        }
    }
    for (int i = 0; i < N; i++) {
        kf->x[i] = xn[i] + m->B[i] * u_throttle_dev;
    }
    /* P = FP F^T + Q, its upper triangle mirrored: P[i][j] = sum_k FP[i][k] F[j][k] */
    float p[N][N] = {{0.0f}};
    for (uint8_t e = 0; e < kf->f_nnz; e++) {
        const uint8_t j = kf->f_row[e], k = kf->f_col[e];
        const float f = m->F[j][k];
        for (int i = 0; i <= j; i++) {
            p[i][j] += kf->f_unit[e] ? fp[i][k] : fp[i][k] * f;
        }
    }
    for (int i = 0; i < N; i++) {
        for (int j = i; j < N; j++) {
            float v = p[i][j] + m->Q[i][j];
            kf->P[i][j] = v;
            kf->P[j][i] = v;
        }
    }
}

/* x += K innovation, P -= K (H P) for one scalar measurement: ph = P H^T, hph = H P H^T. The
 * upper triangle of P is updated and mirrored (K ph^T is symmetric: ph ph^T / s). */
static void scalar_update(altitude_kf_t *kf, const float ph[N], float innovation, float hph, float r)
{
    float inv_s = 1.0f / (hph + r);
    float k[N];
    for (int i = 0; i < N; i++) {
        k[i] = ph[i] * inv_s;
        kf->x[i] += k[i] * innovation;
    }
    for (int i = 0; i < N; i++) {
        for (int j = i; j < N; j++) {
            float v = kf->P[i][j] - k[i] * ph[j];
            kf->P[i][j] = v;
            kf->P[j][i] = v;
        }
    }
}

/* State i's variance set to var, uncorrelated with the others (P stays valid). */
static void reset_variance(altitude_kf_t *kf, int i, float var)
{
    for (int j = 0; j < N; j++) {
        kf->P[i][j] = 0.0f;
        kf->P[j][i] = 0.0f;
    }
    kf->P[i][i] = var;
}

void altitude_kf_loosen_height(altitude_kf_t *kf, float z_var_m2)
{
    reset_variance(kf, 0, z_var_m2);
}

void altitude_kf_move_to(altitude_kf_t *kf, float z_m, float vz_mps, float z_var_m2, float vz_var_m2)
{
    kf->x[0] = z_m;
    kf->x[1] = vz_mps;
    kf->x[3] = 0.0f;
    reset_variance(kf, 0, z_var_m2);
    reset_variance(kf, 1, vz_var_m2);
    reset_variance(kf, 3, ALTITUDE_KF_P0_D);
    kf->baro_reject_run = 0;
}

/* Gate and fuse one barometer reading; true if it was fused. */
static bool update_baro(altitude_kf_t *kf, float z_baro_m, float r_m2)
{
    float innovation = z_baro_m - kf->x[0];
    float p_zz = kf->P[0][0];
    float ph[N];
    if (innovation * innovation > kf->p.baro_gate_chi2 * (p_zz + r_m2)) {
        kf->counters.baro_rejected++;
        kf->baro_reject_run++;
        if (kf->baro_reject_run < kf->p.baro_gate_max_rejects) {
            return false;
        }
        /* disagreeing for the whole timeout: believe the barometer again, at once */
        kf->counters.baro_reanchored++;
        altitude_kf_loosen_height(kf, innovation * innovation);
    }
    kf->baro_reject_run = 0;
    for (int i = 0; i < N; i++) {
        ph[i] = kf->P[i][0];
    }
    scalar_update(kf, ph, innovation, ph[0], r_m2);
    return true;
}

static void update_acc(altitude_kf_t *kf, float a_up_mps2)
{
    float ph[N];
    for (int i = 0; i < N; i++) {
        ph[i] = (kf->P[i][2] + kf->P[i][3]) + kf->P[i][4];
    }
    float innovation = a_up_mps2 - ((kf->x[2] + kf->x[3]) + kf->x[4]);
    scalar_update(kf, ph, innovation, (ph[2] + ph[3]) + ph[4], kf->p.r_acc_m2ps4);
}

bool altitude_kf_update(altitude_kf_t *kf, bool baro_valid, float z_baro_m, bool acc_valid, float a_up_mps2,
                        float baro_r_scale)
{
    bool fused = true;
    if (baro_valid) {
        if (isfinite(z_baro_m)) {
            fused = update_baro(kf, z_baro_m, kf->p.r_baro_m2 * baro_r_scale);
        } else {
            kf->counters.nonfinite_baro++;
        }
    }
    if (acc_valid) {
        if (isfinite(a_up_mps2)) {
            update_acc(kf, a_up_mps2);
        } else {
            kf->counters.nonfinite_acc++;
        }
    }
    return fused;
}

void altitude_kf_update_at_rest(altitude_kf_t *kf)
{
    float ph[N];
    for (int i = 0; i < N; i++) {
        ph[i] = kf->P[i][1];
    }
    scalar_update(kf, ph, -kf->x[1], ph[1], kf->p.r_rest_vz_m2ps2);
}
