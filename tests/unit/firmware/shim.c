/*
 * shim.c - what the ctypes tests need beyond the modules' own functions: the state structs'
 * sizes, params made from scalars (with the generated design), and the state read back into
 * plain arrays. Built with the modules into one host library (tests/unit/firmware/cfw.py).
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "fc_design.h"
#include "control/landing.h"
#include "control/lqi_altitude.h"
#include "control/memory_attitude.h"
#include "control/mixer.h"
#include "control/reference.h"
#include "control/yaw_rate.h"
#include "estimation/altitude_kf.h"
#include "estimation/baro_motion.h"
#include "estimation/plausibility.h"

size_t shim_sizeof(int which)
{
    switch (which) {
    case 0: return sizeof(altitude_kf_t);
    case 1: return sizeof(plausibility_t);
    case 2: return sizeof(baro_motion_t);
    case 3: return sizeof(prefilter3_t);
    case 4: return sizeof(memory_attitude_t);
    case 5: return sizeof(yaw_rate_t);
    case 6: return sizeof(lqi_altitude_t);
    case 7: return sizeof(mixer_t);
    case 8: return sizeof(landing_descent_t);
    case 9: return sizeof(hover_throttle_t);
    case 10: return sizeof(touchdown_accel_t);
    case 11: return sizeof(flat_line_t);
    default: return 0;
    }
}

/* -- the generated design ------------------------------------------------------------------ */
void shim_design_read(float F[25], float B[5], float Q[25], float lqi[4], float *T_s)
{
    memcpy(F, FC_DESIGN_KF_MODEL.F, sizeof FC_DESIGN_KF_MODEL.F);
    memcpy(B, FC_DESIGN_KF_MODEL.B, sizeof FC_DESIGN_KF_MODEL.B);
    memcpy(Q, FC_DESIGN_KF_MODEL.Q, sizeof FC_DESIGN_KF_MODEL.Q);
    lqi[0] = FC_DESIGN_LQI_GAINS.f_z;
    lqi[1] = FC_DESIGN_LQI_GAINS.f_vz;
    lqi[2] = FC_DESIGN_LQI_GAINS.f_az;
    lqi[3] = FC_DESIGN_LQI_GAINS.f_r;
    *T_s = FC_DESIGN_T_S;
}

/* -- altitude KF ---------------------------------------------------------------------------- */
void shim_kf_init(altitude_kf_t *kf, float r_baro_m2, float r_acc, float r_rest_vz, float chi2, int64_t timeout_ns,
                  int64_t period_ns)
{
    altitude_kf_params_t p = {
        .model = &FC_DESIGN_KF_MODEL,
        .r_baro_m2 = r_baro_m2,
        .r_acc_m2ps4 = r_acc,
        .r_rest_vz_m2ps2 = r_rest_vz,
        .baro_gate_chi2 = chi2,
        .baro_gate_max_rejects = altitude_kf_gate_max_rejects(timeout_ns, period_ns),
    };
    altitude_kf_init(kf, &p);
}

void shim_kf_read(const altitude_kf_t *kf, float x[5], float P[25], uint32_t counters[5], uint32_t *run)
{
    memcpy(x, kf->x, sizeof kf->x);
    memcpy(P, kf->P, sizeof kf->P);
    counters[0] = kf->counters.nonfinite_input;
    counters[1] = kf->counters.nonfinite_baro;
    counters[2] = kf->counters.nonfinite_acc;
    counters[3] = kf->counters.baro_rejected;
    counters[4] = kf->counters.baro_reanchored;
    *run = kf->baro_reject_run;
}

/* -- plausibility ----------------------------------------------------------------------------- */
bool shim_plaus_init(plausibility_t *pl, float max_step_Pa, uint16_t flat_n, float flat_std_Pa, float accel_max_g,
                     float tol_mps2, float offset_tau_s, float offset_max_mps2, float T_s)
{
    plausibility_params_t p = {max_step_Pa, flat_n, flat_std_Pa, accel_max_g, tol_mps2, offset_tau_s, offset_max_mps2, T_s};
    return plausibility_init(pl, &p);
}

void shim_plaus_read(const plausibility_t *pl, uint32_t counters[6], bool *flat)
{
    counters[0] = pl->counters.baro_out_of_range;
    counters[1] = pl->counters.baro_flat;
    counters[2] = pl->counters.baro_step;
    counters[3] = pl->counters.accel_out_of_range;
    counters[4] = pl->counters.accel_disagrees_xsens;
    counters[5] = pl->counters.accel_offset_moved;
    *flat = plausibility_baro_flat(pl);
}

float shim_flat_var(const flat_line_t *fl)
{
    float mean = fl->s1 / (float)fl->n;
    return fl->s2 / (float)fl->n - mean * mean;
}

/* -- barometer motion ----------------------------------------------------------------------- */
bool shim_bm_init(baro_motion_t *bm, int64_t window_ns, int64_t block_ns, float max_m)
{
    baro_motion_params_t p;
    if (!baro_motion_params_make(&p, window_ns, block_ns, max_m)) {
        return false;
    }
    baro_motion_init(bm, &p);
    return true;
}

void shim_bm_read(const baro_motion_t *bm, uint32_t counters[3], float *worst_m, uint16_t *blocks_back)
{
    counters[0] = bm->counters.windows;
    counters[1] = bm->counters.disagreements;
    counters[2] = bm->counters.taken_back;
    *worst_m = bm->worst_m;
    *blocks_back = bm->p.blocks_back;
}

/* -- prefilter ---------------------------------------------------------------------------------- */
bool shim_pf_init(prefilter3_t *pf, float omega_radps, float T_s)
{
    prefilter3_params_t p;
    if (!prefilter3_params_make(&p, omega_radps, T_s)) {
        return false;
    }
    prefilter3_init(pf, &p);
    return true;
}

void shim_pf_params(const prefilter3_t *pf, float a[9], float b[3])
{
    memcpy(a, pf->p.a, sizeof pf->p.a);
    memcpy(b, pf->p.b, sizeof pf->p.b);
}

void shim_pf_update(prefilter3_t *pf, float cmd, float out[4])
{
    ref_state_t r = prefilter3_update(pf, cmd);
    out[0] = r.angle_rad;
    out[1] = r.rate_radps;
    out[2] = r.acc_radps2;
    out[3] = r.jerk_radps3;
}

void shim_pf_reset(prefilter3_t *pf, float value, float out[4])
{
    ref_state_t r = prefilter3_reset(pf, value);
    out[0] = r.angle_rad;
    out[1] = r.rate_radps;
    out[2] = r.acc_radps2;
    out[3] = r.jerk_radps3;
}

/* -- memory attitude ------------------------------------------------------------------------ */
bool shim_mem_init(memory_attitude_t *c, bool literal, float T_s, float omega1, float omega2, float k0, float J_hat,
                   float tau_ff, float u_limit)
{
    memory_attitude_gains_t g;
    bool ok = literal ? memory_attitude_gains_paper_literal(&g, T_s, k0, J_hat, u_limit)
                      : memory_attitude_gains_from_poles(&g, T_s, omega1, omega2, k0, J_hat, tau_ff, u_limit);
    memory_attitude_init(c, &g);
    return ok;
}

float shim_mem_update(memory_attitude_t *c, const float ref[4], float angle_rad, float rate_radps, bool active)
{
    ref_state_t r = {ref[0], ref[1], ref[2], ref[3]};
    return memory_attitude_update(c, &r, angle_rad, rate_radps, active);
}

void shim_mem_read(const memory_attitude_t *c, float out[6], uint32_t counters[2])
{
    out[0] = c->u_prev_Nm;
    out[1] = c->s_prev_radps;
    out[2] = c->eta_prev_radps2;
    out[3] = c->s_radps;
    out[4] = c->g.w1_per_s;
    out[5] = c->g.w2_per_s;
    counters[0] = c->counters.nonfinite_input;
    counters[1] = c->counters.nonfinite_applied;
}

/* -- yaw rate --------------------------------------------------------------------------------- */
bool shim_yaw_init(yaw_rate_t *c, float kp, float ki, float u_limit, float T_s)
{
    yaw_rate_params_t p = {kp, ki, u_limit, T_s};
    return yaw_rate_init(c, &p);
}

void shim_yaw_read(const yaw_rate_t *c, float out[2], uint32_t counters[2])
{
    out[0] = c->i_Nm;
    out[1] = c->u_req_Nm;
    counters[0] = c->counters.nonfinite_input;
    counters[1] = c->counters.nonfinite_applied;
}

/* -- LQI ------------------------------------------------------------------------------------------ */
bool shim_lqi_init(lqi_altitude_t *c, float T_s, float m_kg, float F_max_N)
{
    lqi_altitude_params_t p;
    bool ok = lqi_altitude_params_make(&p, &FC_DESIGN_LQI_GAINS, T_s, m_kg, F_max_N);
    lqi_altitude_init(c, &p);
    return ok;
}

void shim_lqi_read(const lqi_altitude_t *c, float out[3], uint32_t *nonfinite)
{
    out[0] = c->x_r_m_s;
    out[1] = c->last_u;
    out[2] = c->p.d_h;
    *nonfinite = c->counters.nonfinite_input;
}

/* -- mixer ---------------------------------------------------------------------------------------- */
bool shim_mixer_init(mixer_t *mx, int frame, float arm_m, float F_max_motor_N, float kq_over_kt_m, int differential,
                     float hover_throttle)
{
    mixer_params_t p = {(mixer_frame_t)frame, arm_m, F_max_motor_N, kq_over_kt_m, (mixer_differential_t)differential,
                        hover_throttle};
    return mixer_init(mx, &p);
}

/* out: throttle[4], applied_tau[3], saturated, applied_collective, applied_command[3] */
void shim_mixer_mix(mixer_t *mx, float collective, const float tau[3], float out[12])
{
    mixer_out_t o;
    mixer_mix(mx, collective, tau, &o);
    memcpy(out, o.throttle, sizeof o.throttle);
    memcpy(out + 4, o.applied_tau_Nm, sizeof o.applied_tau_Nm);
    out[7] = o.saturated ? 1.0f : 0.0f;
    out[8] = o.applied_collective_throttle;
    memcpy(out + 9, o.applied_command_Nm, sizeof o.applied_command_Nm);
}

void shim_mixer_read(const mixer_t *mx, float m[12], uint32_t counters[2])
{
    memcpy(m, mx->m_roll, sizeof mx->m_roll);
    memcpy(m + 4, mx->m_pitch, sizeof mx->m_pitch);
    memcpy(m + 8, mx->m_yaw, sizeof mx->m_yaw);
    counters[0] = mx->counters.nonfinite_collective;
    counters[1] = mx->counters.nonfinite_torque;
}

void shim_kf_write(altitude_kf_t *kf, const float x[5], const float P[25], uint32_t run)
{
    memcpy(kf->x, x, sizeof kf->x);
    memcpy(kf->P, P, sizeof kf->P);
    kf->baro_reject_run = run;
}
