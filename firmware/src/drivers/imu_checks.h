/*
 * Value plausibility of IMU samples: what the one-byte Xbus checksum cannot promise (about 1
 * in 256 frames corrupted on the wire still matches). As flightcode/drivers/imu_checks.py: a
 * sample is refused when a value is not finite, lies beyond what any MTi measures (2000 deg/s,
 * 200 m/s^2, the Euler limits), or moved further since the last accepted sample than the
 * airframe can (2000 deg/s + 0.5 deg; 1000 rad/s^2 + 0.5 rad/s).
 */
#ifndef FW_IMU_CHECKS_H
#define FW_IMU_CHECKS_H

#include <stdbool.h>

typedef enum {
    IMU_PLAUSIBLE = 0,
    IMU_NOT_FINITE,
    IMU_ANGLE_OUT_OF_RANGE,
    IMU_RATE_OUT_OF_RANGE,
    IMU_FORCE_OUT_OF_RANGE,
    IMU_ANGLE_JUMP, /* a jump that persists is the vehicle's: the driver believes it after 3 */
    IMU_RATE_JUMP
} imu_verdict_t;

#define IMU_MAX_RATE_RADPS (2000.0f * 0.017453292519943295f)
#define IMU_MAX_ANGULAR_ACCEL_RADPS2 1000.0f
#define IMU_MAX_SPECIFIC_FORCE_MPS2 200.0f

/* last_euler/last_omega: the last accepted sample's (NULL for the first); dt_s since it. */
imu_verdict_t imu_implausible(const float euler_rad[3], const float omega_radps[3], const float f_mps2[3],
                              const float *last_euler, const float *last_omega, float dt_s);

static inline bool imu_verdict_is_jump(imu_verdict_t v) { return v == IMU_ANGLE_JUMP || v == IMU_RATE_JUMP; }

#endif
