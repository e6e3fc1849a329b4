/*
 * Flight modes: arming, take-off, landing and failsafe as one table over enums, as
 * flightcode/modes.py (docs/flightcode.md "Modes"). modes_update() is fed once per IMU
 * sample with the sample's sensor time and modes_imu_lost() once per IMU read timeout; an
 * update turns the inputs into at most one event and looks it up in the transition table;
 * an event with no entry for the current mode is ignored. Every timer runs on sensor time.
 *
 *   event            condition (held continuously on sensor time)
 *   BOOT_DONE        the barometer reference is fixed
 *   ARM_GESTURE      RC valid, throttle <= 1050 us and yaw >= 1900 us for 1 s
 *   DISARM_GESTURE   RC valid, throttle <= 1050 us and yaw <= 1100 us for 1 s
 *   TAKEOFF          altitude setpoint > takeoff threshold
 *   LANDED           ground contact and |vz estimate| < landed_vz_mps for landed_s
 *   IDLE_TIMEOUT     armed on the ground for auto_disarm_s
 *   RC_LOST          no good RC frame for failsafe.rc_loss_s (judged by the loop)
 *   IMU_LOST         the IMU read timed out
 *   IMU_BACK         a sample arrived again: disarmed, re-arm to fly
 *
 * Ground contact (judged every sample while the controllers fly): a landing is being flown,
 * the estimate is below landed_alt_m, the collective applied is below landed_collective_ratio
 * x the hover collective and the measured vertical acceleration (low-passed) is within
 * landed_accel_mps2 of zero. The RC failsafe latches until the vehicle is disarmed.
 */
#ifndef FW_MODES_H
#define FW_MODES_H

#include <stdbool.h>
#include <stdint.h>

/* The value is what telemetry sends. */
typedef enum {
    MODE_BOOT = 0,
    MODE_DISARMED = 1,
    MODE_ARMED = 2,
    MODE_FLYING = 3,
    MODE_FAILSAFE_RC = 4,
    MODE_FAILSAFE_IMU = 5,
    MODE_COUNT = 6
} fc_mode_t;

typedef enum {
    EV_BOOT_DONE = 0,
    EV_ARM_GESTURE,
    EV_DISARM_GESTURE,
    EV_TAKEOFF,
    EV_LANDED,
    EV_IDLE_TIMEOUT,
    EV_RC_LOST,
    EV_IMU_LOST,
    EV_IMU_BACK,
    EV_COUNT
} mode_event_t;

typedef enum { MOTORS_MINIMUM = 0, MOTORS_IDLE, MOTORS_CONTROL } motor_policy_t;

/* TRANSITIONS[mode][event]: the new mode, or -1 (ignored). MOTORS[mode]. AT_REST[mode]:
 * the vehicle stands on the ground (not FAILSAFE_IMU: that one can start in the air). */
extern const int8_t MODE_TRANSITIONS[MODE_COUNT][EV_COUNT];
extern const motor_policy_t MODE_MOTORS[MODE_COUNT];
extern const bool MODE_AT_REST[MODE_COUNT];

const char *mode_name(fc_mode_t m);   /* "boot", "disarmed", ... */
const char *mode_event_name(mode_event_t e); /* "boot_done", ... */

typedef struct {
    float gesture_throttle_max_us, arm_yaw_min_us, disarm_yaw_max_us;
    int64_t gesture_hold_ns;
    float landed_alt_m, landed_vz_mps, landed_collective_ratio, landed_accel_mps2;
    int64_t landed_ns, auto_disarm_ns;
    float takeoff_alt_m;
} modes_params_t;

/* True once a condition has held continuously for hold_ns of sensor time. */
typedef struct {
    int64_t hold_ns;
    bool holding;
    int64_t since_ns;
} mode_hold_t;

typedef struct {
    int64_t t_ns;
    fc_mode_t old_mode, new_mode;
    mode_event_t event;
} mode_transition_t;

#define MODES_MAX_TRANSITIONS 4

typedef struct {
    modes_params_t p;
    fc_mode_t mode;
    mode_hold_t arm, disarm, landed, idle;
    int64_t t_ns;
    bool ground_contact;       /* the last sample's test (false unless the controllers fly) */
    bool resting;              /* in modes at rest without a break ... */
    int64_t resting_since_ns;  /* ... since this sensor time (boot: 0) */
    mode_transition_t transitions[MODES_MAX_TRANSITIONS]; /* since the caller last cleared them */
    uint8_t n_transitions;
} modes_t;

void modes_init(modes_t *m, const modes_params_t *params);

typedef struct {
    bool baro_ready, rc_valid;
    float throttle_us, yaw_us;    /* latest stick pulses (ignored unless rc_valid) */
    float z_ref_m;                /* the altitude setpoint in force (sticks, or the landing descent) */
    float z_hat_m, vz_hat_mps;    /* the altitude estimate, z up */
    float collective;             /* collective applied over the last sample (0 unless controlling) */
    float hover_collective;       /* the collective that holds the vehicle in the air */
    float a_up_mps2;              /* measured vertical acceleration, low-passed, up */
} modes_input_t;

/* One sample at sensor time t_ns; returns the (possibly new) mode. */
fc_mode_t modes_update(modes_t *m, int64_t t_ns, const modes_input_t *in);
/* The IMU read timed out (the watchdog); returns the new mode. */
fc_mode_t modes_imu_lost(modes_t *m);

static inline motor_policy_t modes_motors(const modes_t *m) { return MODE_MOTORS[m->mode]; }
static inline bool modes_controllers_active(const modes_t *m) { return MODE_MOTORS[m->mode] == MOTORS_CONTROL; }
static inline bool modes_at_rest(const modes_t *m) { return MODE_AT_REST[m->mode]; }

#endif
