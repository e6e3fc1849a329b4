/* IMU value plausibility: see imu_checks.h. */
#include "drivers/imu_checks.h"

#include <math.h>

#define PI_F 3.14159265358979f
#define ANGLE_NOISE_RAD (0.5f * 0.017453292519943295f)
#define RATE_NOISE_RADPS 0.5f

/* a wrapped into [-pi, pi), rad */
static float wrapped(float a)
{
    float m = fmodf(a + PI_F, 2.0f * PI_F);
    if (m < 0.0f)
        m += 2.0f * PI_F;
    return m - PI_F;
}

imu_verdict_t imu_implausible(const float euler_rad[3], const float omega_radps[3], const float f_mps2[3],
                              const float *last_euler, const float *last_omega, float dt_s)
{
    static const float limits[3] = {PI_F, PI_F / 2.0f, PI_F};
    for (int i = 0; i < 3; i++)
        if (!isfinite(euler_rad[i]) || !isfinite(omega_radps[i]) || !isfinite(f_mps2[i]))
            return IMU_NOT_FINITE;
    for (int i = 0; i < 3; i++)
        if (fabsf(euler_rad[i]) > limits[i])
            return IMU_ANGLE_OUT_OF_RANGE;
    for (int i = 0; i < 3; i++)
        if (fabsf(omega_radps[i]) > IMU_MAX_RATE_RADPS)
            return IMU_RATE_OUT_OF_RANGE;
    for (int i = 0; i < 3; i++)
        if (fabsf(f_mps2[i]) > IMU_MAX_SPECIFIC_FORCE_MPS2)
            return IMU_FORCE_OUT_OF_RANGE;
    if (last_euler == 0 || last_omega == 0)
        return IMU_PLAUSIBLE;
    {
        float max_turn = IMU_MAX_RATE_RADPS * dt_s + ANGLE_NOISE_RAD;
        float max_change = IMU_MAX_ANGULAR_ACCEL_RADPS2 * dt_s + RATE_NOISE_RADPS;
        for (int i = 0; i < 3; i++)
            if (fabsf(wrapped(euler_rad[i] - last_euler[i])) > max_turn)
                return IMU_ANGLE_JUMP;
        for (int i = 0; i < 3; i++)
            if (fabsf(omega_radps[i] - last_omega[i]) > max_change)
                return IMU_RATE_JUMP;
    }
    return IMU_PLAUSIBLE;
}
