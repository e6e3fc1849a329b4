/* baro_motion.c - see baro_motion.h. */
#include "estimation/baro_motion.h"

#include <math.h>
#include <string.h>

bool baro_motion_params_make(baro_motion_params_t *params, int64_t window_ns, int64_t block_ns, float max_m)
{
    memset(params, 0, sizeof *params);
    if (window_ns == 0) {
        return true; /* off */
    }
    if (block_ns <= 0 || window_ns < 2 * block_ns || !(isfinite(max_m) && max_m > 0.0f)) {
        return false;
    }
    /* round(window / block), half to even as Python's round() */
    int64_t q = window_ns / block_ns;
    int64_t r2 = 2 * (window_ns % block_ns);
    if (r2 > block_ns || (r2 == block_ns && (q & 1) != 0)) {
        q++;
    }
    if (q > (int64_t)BARO_MOTION_MAX_BLOCKS - 1) {
        return false;
    }
    params->enabled = true;
    params->block_ns = block_ns;
    params->blocks_back = (uint16_t)q;
    params->max_m = max_m;
    return true;
}

static void open_block(baro_motion_t *bm)
{
    bm->m = 0;
    bm->n = 0;
    bm->tainted = false;
    bm->st = bm->sb = bm->sz = bm->shat = 0.0f;
    bm->full = false;
}

/* Forget the window: the next judged sample starts the integrals and a block. */
static void restart(baro_motion_t *bm)
{
    bm->ring_head = 0;
    bm->ring_len = 0;
    bm->blocks = 0;
    bm->v_mps = 0.0f;
    bm->z_m = 0.0f;
    bm->elapsed_ns = 0;
    bm->rebase_ns = 0;
    bm->block_end_ns = bm->p.block_ns;
    open_block(bm);
}

void baro_motion_init(baro_motion_t *bm, const baro_motion_params_t *params)
{
    memset(bm, 0, sizeof *bm);
    bm->p = *params;
    restart(bm);
}

static float now_s(const baro_motion_t *bm)
{
    return (float)(bm->elapsed_ns - bm->rebase_ns) * 1e-9f;
}

/* Move the float time and height origins to now (the end of the newest block). */
static void rebase(baro_motion_t *bm)
{
    const uint16_t cap = (uint16_t)(bm->p.blocks_back + 1u);
    float t0 = now_s(bm);
    float z0 = bm->z_m;
    for (uint16_t k = 0; k < bm->ring_len; k++) {
        baro_motion_block_t *b = &bm->ring[(bm->ring_head + k) % cap];
        b->t_s -= t0;
        b->t_end_s -= t0;
        b->z_in_m -= z0;
        b->z_in_end_m -= z0;
    }
    bm->rebase_ns = bm->elapsed_ns;
    bm->z_m = 0.0f;
}

/* Compare the height changes from first to last; refuse, or take back. */
static void judge(baro_motion_t *bm, const baro_motion_block_t *first, const baro_motion_block_t *last)
{
    bm->counters.windows++;
    /* the inertial height from the end of the first block, started at the estimator's
     * velocity there: h(t) = z(t) - z(t0) - (v(t0) - vz_hat(t0)) (t - t0) */
    float slip = first->v_in_end_mps - first->vz_hat_end_mps;
    float d_inertial = (last->z_in_m - first->z_in_m) - slip * (last->t_s - first->t_s);
    float disagreement = fabsf((last->baro_m - first->baro_m) - d_inertial);
    if (!bm->refusing) {
        if (disagreement > bm->worst_m) {
            bm->worst_m = disagreement;
        }
        if (disagreement > bm->p.max_m) {
            bm->refusing = true;
            bm->counters.disagreements++;
            float h_end = (last->z_in_end_m - first->z_in_end_m) - slip * (last->t_end_s - first->t_end_s);
            bm->reanchor_z_m = first->z_hat_end_m + h_end;
            bm->reanchor_vz_mps = (first->vz_hat_end_mps + last->v_in_end_mps) - first->v_in_end_mps;
            bm->have_reanchor = true;
        }
    } else if (disagreement <= bm->p.max_m && fabsf(last->baro_m - last->z_hat_m) <= bm->p.max_m) {
        bm->refusing = false;
        bm->counters.taken_back++;
    }
}

static void close_block(baro_motion_t *bm)
{
    const uint16_t cap = (uint16_t)(bm->p.blocks_back + 1u);
    bm->block_end_ns += bm->p.block_ns;
    if (2u * bm->n < bm->m || bm->tainted) {
        /* a gap: the window starts again after it */
        bm->ring_head = 0;
        bm->ring_len = 0;
        open_block(bm);
        rebase(bm);
        return;
    }
    float inv_n = 1.0f / (float)bm->n;
    baro_motion_block_t block = {
        .t_s = bm->st * inv_n,
        .baro_m = bm->sb * inv_n,
        .z_in_m = bm->sz * inv_n,
        .z_hat_m = bm->shat * inv_n,
        .t_end_s = now_s(bm),
        .z_in_end_m = bm->z_m,
        .v_in_end_mps = bm->v_mps,
        .z_hat_end_m = bm->full_z_hat_m,
        .vz_hat_end_mps = bm->full_vz_hat_mps,
    };
    open_block(bm);
    if (bm->ring_len == cap) { /* the oldest block leaves the window */
        bm->ring_head = (uint16_t)((bm->ring_head + 1u) % cap);
        bm->ring_len--;
    }
    bm->ring[(bm->ring_head + bm->ring_len) % cap] = block;
    bm->ring_len++;
    bm->blocks++;
    rebase(bm);
    /* a whole window since the last gap, and the estimator's velocity trusted from one window
     * after the judging started */
    if (bm->ring_len > bm->p.blocks_back && bm->blocks > 2u * bm->p.blocks_back) {
        judge(bm, &bm->ring[bm->ring_head], &bm->ring[(bm->ring_head + bm->ring_len - 1u) % cap]);
    }
}

bool baro_motion_add(baro_motion_t *bm, int64_t dt_ns, bool baro_valid, float z_baro_m, bool acc_valid,
                     float a_up_mps2, float z_hat_m, float vz_hat_mps, bool judging)
{
    if (!bm->p.enabled) {
        return false;
    }
    if (acc_valid && isfinite(a_up_mps2)) {
        bm->a_last_mps2 = a_up_mps2;
        bm->have_a = true;
    }
    if (!judging || !bm->have_a || dt_ns <= 0) {
        if (bm->elapsed_ns > 0) {
            restart(bm);
        }
        return bm->refusing;
    }
    if (bm->full) {
        close_block(bm);
    }
    const float a = bm->a_last_mps2;
    const float dt_s = (float)dt_ns * 1e-9f;
    /* the integrals are taken exactly at each sample (the same for both ends of a window) */
    bm->elapsed_ns += dt_ns;
    bm->z_m = (bm->z_m + bm->v_mps * dt_s) + 0.5f * a * dt_s * dt_s;
    bm->v_mps += a * dt_s;
    bm->m++;
    if (baro_valid && isfinite(z_baro_m)) {
        bm->n++;
        bm->st += now_s(bm);
        bm->sb += z_baro_m;
        bm->sz += bm->z_m;
        bm->shat += z_hat_m;
    }
    if (bm->elapsed_ns >= bm->block_end_ns) {
        bm->full = true;
        bm->full_z_hat_m = z_hat_m;
        bm->full_vz_hat_mps = vz_hat_mps;
    }
    return bm->refusing;
}

void baro_motion_reading_rejected(baro_motion_t *bm)
{
    bm->tainted = true;
}

bool baro_motion_take_reanchor(baro_motion_t *bm, float *z_m, float *vz_mps)
{
    if (!bm->have_reanchor) {
        return false;
    }
    *z_m = bm->reanchor_z_m;
    *vz_mps = bm->reanchor_vz_mps;
    bm->have_reanchor = false;
    return true;
}

float baro_motion_take_worst(baro_motion_t *bm)
{
    float out = bm->worst_m;
    bm->worst_m = 0.0f;
    return out;
}

void baro_motion_on_ground(baro_motion_t *bm)
{
    bm->refusing = false;
    bm->have_reanchor = false;
    if (bm->elapsed_ns > 0) {
        restart(bm);
    }
}
