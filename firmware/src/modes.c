/* Flight modes: see modes.h. */
#include "modes.h"

#include <math.h>
#include <string.h>

#define X (-1)
/* columns: BOOT_DONE ARM DISARM TAKEOFF LANDED IDLE_TIMEOUT RC_LOST IMU_LOST IMU_BACK */
const int8_t MODE_TRANSITIONS[MODE_COUNT][EV_COUNT] = {
    [MODE_BOOT] = {MODE_DISARMED, X, X, X, X, X, X, X, X},
    [MODE_DISARMED] = {X, MODE_ARMED, X, X, X, X, X, MODE_FAILSAFE_IMU, X},
    [MODE_ARMED] = {X, X, MODE_DISARMED, MODE_FLYING, X, MODE_DISARMED, MODE_DISARMED, MODE_FAILSAFE_IMU, X},
    [MODE_FLYING] = {X, X, X, X, MODE_ARMED, X, MODE_FAILSAFE_RC, MODE_FAILSAFE_IMU, X},
    [MODE_FAILSAFE_RC] = {X, X, X, X, MODE_DISARMED, X, X, MODE_FAILSAFE_IMU, X},
    [MODE_FAILSAFE_IMU] = {X, X, X, X, X, X, X, X, MODE_DISARMED},
};
#undef X

const motor_policy_t MODE_MOTORS[MODE_COUNT] = {
    [MODE_BOOT] = MOTORS_MINIMUM,    [MODE_DISARMED] = MOTORS_MINIMUM,   [MODE_ARMED] = MOTORS_IDLE,
    [MODE_FLYING] = MOTORS_CONTROL,  [MODE_FAILSAFE_RC] = MOTORS_CONTROL, [MODE_FAILSAFE_IMU] = MOTORS_MINIMUM,
};

const bool MODE_AT_REST[MODE_COUNT] = {
    [MODE_BOOT] = true, [MODE_DISARMED] = true, [MODE_ARMED] = true,
    [MODE_FLYING] = false, [MODE_FAILSAFE_RC] = false, [MODE_FAILSAFE_IMU] = false,
};

const char *mode_name(fc_mode_t m)
{
    static const char *const names[MODE_COUNT] = {"boot", "disarmed", "armed", "flying", "failsafe_rc",
                                                  "failsafe_imu"};
    return (unsigned)m < MODE_COUNT ? names[m] : "?";
}

const char *mode_event_name(mode_event_t e)
{
    static const char *const names[EV_COUNT] = {"boot_done", "arm_gesture", "disarm_gesture", "takeoff", "landed",
                                                "idle_timeout", "rc_lost", "imu_lost", "imu_back"};
    return (unsigned)e < EV_COUNT ? names[e] : "?";
}

static bool hold_update(mode_hold_t *h, bool condition, int64_t t_ns)
{
    if (!condition) {
        h->holding = false;
        return false;
    }
    if (!h->holding) {
        h->holding = true;
        h->since_ns = t_ns;
    }
    return t_ns - h->since_ns >= h->hold_ns;
}

void modes_init(modes_t *m, const modes_params_t *params)
{
    memset(m, 0, sizeof *m);
    m->p = *params;
    m->mode = MODE_BOOT;
    m->arm.hold_ns = params->gesture_hold_ns;
    m->disarm.hold_ns = params->gesture_hold_ns;
    m->landed.hold_ns = params->landed_ns;
    m->idle.hold_ns = params->auto_disarm_ns;
    m->resting = true; /* boot starts at rest at sensor time 0 */
    m->resting_since_ns = 0;
}

static bool fire(modes_t *m, mode_event_t event, int64_t t_ns)
{
    int8_t next = MODE_TRANSITIONS[m->mode][event];
    fc_mode_t new_mode;
    if (next < 0)
        return false;
    new_mode = (fc_mode_t)next;
    if (m->n_transitions < MODES_MAX_TRANSITIONS) {
        mode_transition_t *tr = &m->transitions[m->n_transitions++];
        tr->t_ns = t_ns;
        tr->old_mode = m->mode;
        tr->new_mode = new_mode;
        tr->event = event;
    }
    if (!MODE_AT_REST[new_mode]) {
        m->resting = false;
    } else if (!MODE_AT_REST[m->mode]) {
        m->resting = true;
        m->resting_since_ns = t_ns;
    }
    m->mode = new_mode;
    m->ground_contact = false; /* judged again in the new mode */
    m->arm.holding = m->disarm.holding = m->landed.holding = m->idle.holding = false;
    return true;
}

fc_mode_t modes_imu_lost(modes_t *m)
{
    fire(m, EV_IMU_LOST, m->t_ns);
    return m->mode;
}

fc_mode_t modes_update(modes_t *m, int64_t t_ns, const modes_input_t *in)
{
    const modes_params_t *p = &m->p;
    bool low, on_ground;
    m->t_ns = t_ns;
    m->ground_contact = MODE_MOTORS[m->mode] == MOTORS_CONTROL && in->z_ref_m <= p->takeoff_alt_m &&
                        in->z_hat_m < p->landed_alt_m &&
                        in->collective < p->landed_collective_ratio * in->hover_collective &&
                        fabsf(in->a_up_mps2) < p->landed_accel_mps2;
    if (m->mode == MODE_FAILSAFE_IMU) {
        fire(m, EV_IMU_BACK, t_ns);
        return m->mode;
    }
    if (m->mode == MODE_BOOT) {
        if (in->baro_ready)
            fire(m, EV_BOOT_DONE, t_ns);
        return m->mode;
    }
    if (!in->rc_valid && fire(m, EV_RC_LOST, t_ns))
        return m->mode;
    low = in->rc_valid && in->throttle_us <= p->gesture_throttle_max_us;
    if (hold_update(&m->arm, low && in->yaw_us >= p->arm_yaw_min_us, t_ns) && fire(m, EV_ARM_GESTURE, t_ns))
        return m->mode;
    if (hold_update(&m->disarm, low && in->yaw_us <= p->disarm_yaw_max_us, t_ns) &&
        fire(m, EV_DISARM_GESTURE, t_ns))
        return m->mode;
    if (in->z_ref_m > p->takeoff_alt_m && fire(m, EV_TAKEOFF, t_ns))
        return m->mode;
    on_ground = m->ground_contact && fabsf(in->vz_hat_mps) < p->landed_vz_mps;
    if (hold_update(&m->landed, on_ground, t_ns) && fire(m, EV_LANDED, t_ns))
        return m->mode;
    if (hold_update(&m->idle, m->mode == MODE_ARMED, t_ns))
        fire(m, EV_IDLE_TIMEOUT, t_ns);
    return m->mode;
}
