/*
 * RC input: PPM edges from the HAL's capture (decoded by ppm.h) or SBUS frames from the HAL's
 * RC UART, polled once a sample without blocking. The newest good frame is kept with the
 * sensor time of the sample that completed it; the loop judges RC loss on sensor time.
 */
#ifndef FW_RC_H
#define FW_RC_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/ppm.h"
#include "drivers/sbus.h"

#define RC_MAX_CHANNELS 16

typedef struct {
    bool valid;     /* a frame has been decoded */
    int64_t t_ns;   /* sensor time of the sample that completed it */
    uint8_t n;
    float channels_us[RC_MAX_CHANNELS];
} rc_frame_t;

typedef struct {
    bool sbus;
    ppm_decoder_t ppm;
    int64_t stale_ns;
    bool have_rx;
    int64_t last_rx_ns;
    sbus_parser_t sbus_parser;
    float sbus_scale_us, sbus_offset_us;
    uint32_t sbus_frame_lost_flags, sbus_failsafe_frames, sbus_frames;
    rc_frame_t latest;
} rc_input_t;

void rc_init_capture(rc_input_t *rc, const ppm_params_t *params);
void rc_init_sbus(rc_input_t *rc, float scale_us, float offset_us);
/* Read whatever arrived and decode it: 1 a new frame, 0 none, < 0 a port error. */
int rc_poll(rc_input_t *rc, int64_t t_ns);
/* The RC errors telemetry counts: wire errors of the layer + the decoder's. */
uint32_t rc_errors(const rc_input_t *rc);

#endif
