/*
 * SBUS receiver frames (as from a PPM-to-SBUS converter), as flightcode/drivers/sbus.py:
 * 25 bytes, 0F header, 16 channels x 11 bits LSB first, flags (bit2 frame lost, bit3
 * failsafe), end byte 00/04/14/24/34. No checksum: a frame is accepted when the header, the
 * end byte and the unused flag bits fit; otherwise the parser slides one byte (counted).
 */
#ifndef FW_SBUS_H
#define FW_SBUS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define SBUS_HEADER 0x0Fu
#define SBUS_FRAME_LEN 25u
#define SBUS_N_CHANNELS 16
#define SBUS_FLAG_FRAME_LOST 0x04u
#define SBUS_FLAG_FAILSAFE 0x08u
#define SBUS_BAUD 100000u

typedef struct {
    uint16_t raw[SBUS_N_CHANNELS];
    uint8_t flags;
} sbus_frame_t;

typedef struct {
    uint32_t garbage_bytes, frames;
} sbus_parser_counters_t;

typedef struct {
    uint8_t buf[64];
    size_t n;
    sbus_parser_counters_t counters;
} sbus_parser_t;

void sbus_parser_init(sbus_parser_t *p);
/* Feed bytes; calls fn for each frame in order. */
void sbus_parser_feed(sbus_parser_t *p, const uint8_t *data, size_t n,
                      void (*fn)(void *ctx, const sbus_frame_t *f), void *ctx);
/* The 16 raw channels from the 22 packed bytes. */
void sbus_decode_channels(const uint8_t payload[22], uint16_t raw[SBUS_N_CHANNELS]);

#endif
