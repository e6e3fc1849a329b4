/*
 * mixer.h - collective throttle + body torques -> four motor throttles, with priorities.
 *
 * The C twin of flightcode/control/mixer.py (its docstring has the derivation). Layout, body
 * FRD, motor i on ESC channel i:
 *
 *     X frame, l = arm / sqrt(2):  0 front-right (+l, +l) CCW   2 front-left (+l, -l) CW
 *                                  1 rear-left   (-l, -l) CCW   3 rear-right (-l, +l) CW
 *     plus frame:                  0 right (0, +a) CCW   1 left (0, -a) CCW
 *                                  2 front (+a, 0) CW    3 back (-a, 0) CW
 *
 * F_i = F_max_motor d_i^2 along -z_B; tau_x = -sum y_i F_i, tau_y = sum x_i F_i,
 * tau_z = (kQ/kT) sum spin_i F_i (spin +1 CCW). Saturation, all in thrust within [0, F_max]:
 * (1) the request fits: apply it; (2) else cut yaw to the largest fraction that fits; (3) if
 * roll/pitch do not fit even without yaw, shift the collective just enough (scaling roll/pitch
 * only if their spread exceeds the thrust range), then give yaw what fits there.
 *
 * Differential: MIXER_DIFF_THRUST mixes in thrust (exact inverse of F = F_max d^2, torque gain
 * 1); MIXER_DIFF_THROTTLE is linear in throttle around the collective, sized at the hover
 * throttle d_h, as the PWM mixers of the paper's era: the request is scaled by d_c / d_h
 * before the thrust-space mix. The applied torques are computed back from the final thrusts;
 * applied_command_Nm is the same in the controllers' units (divided by that gain). Below a
 * collective of about 1e-36 (the LQI never gives one; it gives 0) the float32 torques
 * underflow and applied_command_Nm is 0 where flightcode's doubles give the fraction that fits.
 */
#ifndef FW_CONTROL_MIXER_H
#define FW_CONTROL_MIXER_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { MIXER_FRAME_X = 0, MIXER_FRAME_PLUS = 1 } mixer_frame_t;
typedef enum { MIXER_DIFF_THRUST = 0, MIXER_DIFF_THROTTLE = 1 } mixer_differential_t;

/* A thrust this far outside [0, F_max] still fits: flightcode's 1e-9 N, or the float32
 * rounding of the sums that make it (4 ulps of the largest term, 2e-6 N at a motor's full
 * 5 N), whichever is larger. In double precision flightcode's 1e-9 N is far above its
 * rounding; in single precision a request exactly at a bound would otherwise be taken for a
 * saturated one half the time. */
#define MIXER_EPS_MIN_N 1e-9f
#define MIXER_EPS_REL (4.0f * 1.1920929e-7f)

typedef struct {
    mixer_frame_t frame;               /* vehicle.frame */
    float arm_m;                       /* vehicle.arm_m */
    float F_max_motor_N;               /* vehicle.F_max_N / 4 */
    float kq_over_kt_m;                /* vehicle.kq_over_kt_m */
    mixer_differential_t differential; /* vehicle.mixer */
    float hover_throttle;              /* d_h, in (0, 1): the throttle differential's design point */
} mixer_params_t;

typedef struct {
    float throttle[4];                 /* motor throttles in [0, 1] (pulse = min + (max - min) d) */
    float applied_tau_Nm[3];           /* (roll, pitch, yaw) the clipped thrusts produce, N m FRD */
    bool saturated;                    /* the request was altered */
    float applied_collective_throttle; /* sqrt(sum F / (4 F_max_motor)) */
    float applied_command_Nm[3];       /* applied_tau_Nm in the controllers' units */
} mixer_out_t;

typedef struct {
    uint32_t nonfinite_collective; /* replaced by 0 */
    uint32_t nonfinite_torque;     /* the non-finite axes replaced by 0 */
} mixer_counters_t;

typedef struct {
    mixer_params_t p;
    float per_hover;      /* 1 / d_h for the throttle differential; 0 mixes in thrust */
    float m_roll[4];      /* per-motor thrust per N m of roll, pitch, yaw (the allocation's inverse) */
    float m_pitch[4];
    float m_yaw[4];
    float ny[4];          /* -y_i, x_i, (kQ/kT) spin_i: the allocation's torque rows */
    float px[4];
    float sz[4];
    mixer_counters_t counters;
} mixer_t;

/* False if a value is unusable (arm, F_max, kq/kt not > 0; d_h not in (0, 1); an unknown frame
 * or differential). */
bool mixer_init(mixer_t *mx, const mixer_params_t *params);

/* Throttles for a collective throttle in [0, 1] and a (roll, pitch, yaw) request in N m (FRD). */
void mixer_mix(mixer_t *mx, float collective_throttle, const float tau_Nm[3], mixer_out_t *out);

#ifdef __cplusplus
}
#endif

#endif /* FW_CONTROL_MIXER_H */
