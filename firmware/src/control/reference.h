/*
 * reference.h - third-order critically damped reference prefilter (stick -> smooth reference).
 *
 * The C twin of flightcode/control/reference.py. The memory attitude controller needs the
 * reference and its first three derivatives for the eta feed-forward with the actuator-lag
 * lead (docs/controllers.md 2.5 item 4). The stick command passes through
 *
 *     G(s) = omega^3 / (s + omega)^3
 *
 * in phase-variable form x = [y, y', y''], discretised exactly with a zero-order hold on the
 * command. The discretisation is computed at init in closed form (the triple real pole gives
 * exp(-omega T) times polynomials in T), so a scenario may change the bandwidth at run time.
 * Unit-agnostic: angles in rad give rad, rad/s, rad/s^2, rad/s^3 (the field names say rad
 * because the attitude loop is the main user).
 */
#ifndef FW_CONTROL_REFERENCE_H
#define FW_CONTROL_REFERENCE_H

#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Reference sample: value and its first three time derivatives. */
typedef struct {
    float angle_rad;
    float rate_radps;
    float acc_radps2;
    float jerk_radps3;
} ref_state_t;

typedef struct {
    float a[3][3]; /* ZOH transition */
    float b[3];    /* ZOH input column */
    float w3;      /* omega^3 */
    float c1;      /* 3 omega^2 */
    float c2;      /* 3 omega */
} prefilter3_params_t;

/* The ZOH model for bandwidth omega_radps (> 0) at period T_s (> 0); false if not usable. */
bool prefilter3_params_make(prefilter3_params_t *params, float omega_radps, float T_s);

typedef struct {
    prefilter3_params_t p;
    float y, yd, ydd; /* state */
    float cmd;        /* last finite command (held when a non-finite one comes) */
} prefilter3_t;

/* Copy the params and settle at 0. */
void prefilter3_init(prefilter3_t *pf, const prefilter3_params_t *params);

/* Settle at value (all derivatives zero); returns that state. */
ref_state_t prefilter3_reset(prefilter3_t *pf, float value);

/* Advance one sample with cmd held over it; the jerk is the exact third derivative at the new
 * sample. A non-finite cmd is ignored (the last finite one is held). */
ref_state_t prefilter3_update(prefilter3_t *pf, float cmd);

#ifdef __cplusplus
}
#endif

#endif /* FW_CONTROL_REFERENCE_H */
