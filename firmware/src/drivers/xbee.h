/*
 * XBee-PRO (802.15.4) telemetry downlink in API mode, as flightcode/drivers/xbee.py:
 *   7E len_hi len_lo frame_data... checksum     checksum = 0xFF - (sum(frame_data) & 0xFF)
 * TX16 request: 01 frame_id dest_hi dest_lo options payload (payload <= 100 bytes). With AP=2
 * every byte after the delimiter that is 7E, 7D, 11 or 13 goes as 7D, byte ^ 0x20.
 * The link never blocks the loop: a frame is dropped (counted) while more than
 * max_out_waiting bytes are unsent; bytes from the modem (TX status, anything else) are read
 * without blocking and parsed, so they never pile up.
 */
#ifndef FW_XBEE_H
#define FW_XBEE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define XBEE_START 0x7Eu
#define XBEE_ESCAPE 0x7Du
#define XBEE_XOR 0x20u
#define XBEE_MAX_RF_PAYLOAD 100u
#define XBEE_MAX_FRAME_DATA 256u
#define XBEE_TX16 0x01u
#define XBEE_TX_STATUS 0x89u
/* the longest API frame the link sends, escaped: 2 x (2 + 5 + 100 + 1) + 1 */
#define XBEE_MAX_WIRE 220u

/* A complete API frame for frame_data into out (AP=1, or AP=2 when escaped): its length,
 * or 0 if it does not fit. */
size_t xbee_api_frame(const uint8_t *frame_data, size_t n, bool escaped, uint8_t *out, size_t out_cap);
/* TX16 frame data into out (5 + len bytes): its length, or 0 if the payload is too long. */
size_t xbee_tx16(uint8_t frame_id, uint16_t dest16, const uint8_t *payload, size_t len, uint8_t options,
                 uint8_t *out, size_t out_cap);

typedef struct {
    uint32_t garbage_bytes, bad_length, truncated_frames, checksum_errors, frames;
} xbee_parser_counters_t;

typedef struct {
    bool escaped;
    uint8_t raw[320]; /* the modem sends short frames (TX status: 7 bytes); longer ones are dropped */
    size_t n;
    xbee_parser_counters_t counters;
} xbee_parser_t;

void xbee_parser_init(xbee_parser_t *p, bool escaped);
/* Feed bytes; calls fn with each checked frame's data. */
void xbee_parser_feed(xbee_parser_t *p, const uint8_t *data, size_t n,
                      void (*fn)(void *ctx, const uint8_t *frame, size_t len), void *ctx);

typedef struct {
    uint32_t sent, dropped_busy, short_writes, tx_ok, tx_failed, rx_other;
} xbee_link_counters_t;

typedef struct {
    bool escaped, request_status;
    uint16_t dest16;
    int32_t max_out_waiting;
    uint8_t frame_id;
    xbee_parser_t parser;
    xbee_link_counters_t counters;
} xbee_link_t;

void xbee_link_init(xbee_link_t *l, bool escaped, uint16_t dest16, bool request_status, int32_t max_out_waiting);
/* Queue one TX16 frame on the telemetry UART if the link has room: 1 sent, 0 dropped
 * (counted), < 0 a port error. */
int xbee_link_send(xbee_link_t *l, const uint8_t *payload, size_t len);
/* Read and parse whatever the modem sent (non-blocking); < 0 a port error. */
int xbee_link_drain(xbee_link_t *l);

#endif
