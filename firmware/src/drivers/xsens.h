/*
 * XSENS MTi driver: bring-up (config state, identify, output configuration) and the sample
 * stream, on the HAL's IMU UART. As flightcode/drivers/xsens.py:
 *
 * Bring-up, each step waiting for its ack (MID + 1): GoToConfig resent until 0x31 arrives
 * (a streaming device's samples are skipped); ReqDID (required), ReqProductCode, ReqFWRev
 * (an Error reply is logged, silence is a failure); mk4 SetOutputConfiguration (the ack must
 * echo the request) or legacy SetOutputMode/Settings/Period; GoToMeasurement last
 * (xsens_start), so the first sample is the loop's first tick.
 *
 * Sensor time: t_ns of each sample is the unwrapped SampleTimeFine (10 kHz, u32) since the
 * first sample (legacy: the u16 sample counter times the period). A sample whose
 * SampleTimeFine step disagrees with its packet-counter step by more than 4 periods is
 * rejected (rejected_time_jumps; believed after 3 in a row: time_rebases); one whose values
 * cannot be true is rejected (rejected_values; a jump believed after 3: value_rebases).
 */
#ifndef FW_XSENS_H
#define FW_XSENS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/mtdata.h"
#include "drivers/xbus.h"

#define XSENS_MAX_TIME_SLIP_PERIODS 4
#define XSENS_REBASE_AFTER_REJECTS 3

typedef struct {
    bool legacy;                 /* imu.identity = "legacy" (MTData) instead of "mk4" (MTData2) */
    uint16_t rate_hz;            /* sample rate = loop rate */
    uint32_t goto_config_attempts;
    uint64_t reply_timeout_ns;   /* wait per boot reply */
} xsens_params_t;

typedef struct {
    uint32_t device_id;
    char product_code[24];
    char firmware[16];
} xsens_info_t;

/* One IMU sample for the loop (FRD body, NED world, rad, rad/s, m/s^2). */
typedef struct {
    int64_t t_ns;          /* sensor time since the first sample */
    uint16_t counter;
    float euler_rad[3];    /* roll, pitch, yaw */
    float omega_B_radps[3];
    float f_B_mps2[3];     /* about (0, 0, -9.81) level at rest */
    uint32_t status;
    uint32_t skipped;      /* older complete samples of the same read dropped for this one */
} imu_sample_t;

typedef struct {
    uint32_t gap_samples, gaps, duplicates, skipped_samples;
    uint32_t rejected_time_jumps, time_rebases, rejected_values, value_rebases;
    uint32_t unexpected_messages;
    mtdata_counters_t mtdata;
} xsens_counters_t;

typedef struct {
    xsens_params_t params;
    xbus_parser_t parser;
    xsens_counters_t counters;
    int64_t period_ns;
    size_t frame_len;
    /* the newest decoded sample not yet handed to the loop (messages read with a boot ack) */
    bool pending;
    xsens_data_t pending_data;
    uint32_t pending_skipped;
    /* clock */
    bool have_base;
    uint32_t last_raw;
    int64_t clock_ticks;
    bool have_counter;
    uint16_t last_counter;
    uint32_t rejects_in_row;
    /* value checks */
    bool have_accepted;
    int64_t accepted_t_ns;
    float accepted_euler[3], accepted_omega[3];
    uint32_t value_rejects_in_row;
} xsens_t;

void xsens_init(xsens_t *x, const xsens_params_t *params);

/* GoToConfig, identify and configure; false with the reason in why (the device stays in
 * config state either way). */
bool xsens_bring_up(xsens_t *x, xsens_info_t *info, char *why, size_t why_len);

/* GoToMeasurement; false with the reason. */
bool xsens_start(xsens_t *x, char *why, size_t why_len);

/* Block until the next sample (the newest if several are queued): 1 with *out, 0 when no
 * complete sample arrived within timeout_ns (the IMU-loss watchdog), < 0 a port error. */
int xsens_read_sample(xsens_t *x, uint64_t timeout_ns, imu_sample_t *out);

/* Convert decoded data to a sample on the loop's clock (exposed for tests): false when its
 * time jumps or its values cannot be true (counted). */
bool xsens_to_sample(xsens_t *x, const xsens_data_t *d, uint32_t skipped, imu_sample_t *out);

#endif
