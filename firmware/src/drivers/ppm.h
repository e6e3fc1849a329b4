/*
 * PPM input: the timer-capture record format of the posix front-end (docs/rc-capture-format.md)
 * and the PPM decoder that turns capture edges into channel frames, as
 * flightcode/drivers/ppm_capture.py.
 *
 * Record (6 bytes, one per edge): A5, seq u8, flags (bit0 level after the edge, bit1 overrun,
 * other bits 0), capture u16 little-endian (1 us per count), CRC-8 (poly 0x07, init 0) over
 * bytes 1..4. The parser resyncs on A5 with a valid CRC and drops only that byte otherwise.
 *
 * Decoder (ArduPilot AP_RCProtocol_PPMSum, Betaflight rx_pwm.c): a channel is the time between
 * consecutive edges of the same direction; an interval >= sync_min_us ends a frame; a channel
 * lies strictly between pulse_min_us and pulse_max_us; anything else (a lost edge, an overrun,
 * a sequence gap) drops the frame being assembled. A channel count is accepted after
 * lock_frames consecutive frames of that count.
 */
#ifndef FW_PPM_H
#define FW_PPM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal.h"

#define CAPTURE_SYNC 0xA5u
#define CAPTURE_RECORD_LEN 6u
#define PPM_MAX_CHANNELS 16

uint8_t crc8_smbus(const uint8_t *data, size_t n);

typedef struct {
    uint32_t garbage_bytes, crc_errors, bad_flags;
} capture_counters_t;

typedef struct {
    uint8_t buf[64];
    size_t n;
    capture_counters_t counters;
} capture_parser_t;

void capture_parser_init(capture_parser_t *p);
/* Take up to n bytes into the parser's buffer; returns how many it took (its room). */
size_t capture_parser_push(capture_parser_t *p, const uint8_t *data, size_t n);
/* Records parsed out of the buffer, at most max, as edges into out; returns the count.
 * Garbage, bad CRCs and reserved flag bits drop one byte each (counted). */
size_t capture_parser_pop(capture_parser_t *p, hal_edge_t *out, size_t max);

typedef struct {
    uint16_t sync_min_us, pulse_min_us, pulse_max_us;
    uint8_t min_channels, max_channels, lock_frames;
    bool rising; /* edge = "rising" */
    float stale_ms;
} ppm_params_t;

typedef struct {
    uint32_t sequence_gaps, overruns, missing_edges, bad_pulses, too_many_channels, short_frames, unlocked_frames;
    uint32_t frames, locks, stale_restarts;
} ppm_counters_t;

typedef struct {
    ppm_params_t params;
    ppm_counters_t counters;
    uint8_t level;
    bool have_level, have_t, have_seq, synced;
    uint8_t last_level, last_seq;
    uint16_t last_t;
    uint16_t channels[PPM_MAX_CHANNELS + 1];
    uint8_t n_channels;
    uint8_t candidate, stable;
    uint8_t locked_channels; /* 0 until locked */
} ppm_decoder_t;

void ppm_init(ppm_decoder_t *d, const ppm_params_t *params);
/* Forget the frame being assembled and the edge history (not the lock). */
void ppm_desync(ppm_decoder_t *d);
/* One edge; returns the channel count when a frame with the locked count completes (its
 * widths in out_us), else 0. */
int ppm_edge(ppm_decoder_t *d, const hal_edge_t *e, uint16_t out_us[PPM_MAX_CHANNELS]);

#endif
