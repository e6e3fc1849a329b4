/* The loop's services shared by its steps (loop_parts.c), as flightcode/loop_parts.py:
 * port errors and rare anomalies counted and logged sparsely, the ESC write, stick scaling,
 * the boot references, statistics. Used by loop.c only. */
#ifndef FW_LOOP_PARTS_H
#define FW_LOOP_PARTS_H

#include "loop.h"

/* Count a port error in *count; log it on the 1st, 2nd, 4th, 8th... occurrence. */
void loop_port_error(uint32_t *count, const char *device);
/* Count an in-flight anomaly; true when it is to be logged (1st, 2nd, 4th, ...). */
bool loop_rare(uint32_t *count);
void loop_log_transitions(flight_loop_t *L);
/* One ESC command (NULL: all motors to minimum); a port error is logged, not raised. */
void loop_write_esc(flight_loop_t *L, const float *pulses_us);
/* (roll_cmd rad, pitch_cmd rad, yaw_rate_cmd rad/s, z_ref m, throttle us, yaw us) */
void loop_sticks(const flight_loop_t *L, const float *channels_us, float out[6]);
/* End of the boot averaging: altitude zero, accelerometer offsets, estimator start. */
void loop_fix_references(flight_loop_t *L);
uint32_t loop_telemetry_dropped(const flight_loop_t *L);
void loop_log_stats(flight_loop_t *L, fc_mode_t mode, float z_hat);

#endif
