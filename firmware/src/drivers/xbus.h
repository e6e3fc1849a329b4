/*
 * Xbus framing (XSENS MTi): frame encoder and a resynchronising stream parser.
 *
 * Sans-I/O: bytes in, messages out; no port, no clock. Wire facts (docs/protocols.md 1.2;
 * MT0101P/MT0605P): frame FA FF MID LEN [LENEXT_H LENEXT_L] DATA CS; LEN 0xFF marks a
 * 16-bit extended length; every byte after 0xFA plus CS sums to 0 mod 256; multi-byte fields
 * are big-endian. The parser never fails on peer garbage: it skips to the next FA FF, drops
 * frames whose checksum fails (as the device does) and counts both.
 */
#ifndef FW_XBUS_H
#define FW_XBUS_H

#include <stddef.h>
#include <stdint.h>

#define XBUS_PREAMBLE 0xFAu
#define XBUS_BID_MASTER 0xFFu
#define XBUS_EXTENDED_LEN 0xFFu
/* The parser's buffer: the longest frame it can hold (the largest the flight code meets is
 * a 146-byte MTData2 of a fully configured MTi-300; the measurement frame is 69). */
#define XBUS_BUF_SIZE 512u
#define XBUS_MAX_PAYLOAD (XBUS_BUF_SIZE - 7u)

/* Message identifiers the flight code uses (acks are MID + 1). */
typedef enum {
    XBUS_REQ_DID = 0x00,
    XBUS_DEVICE_ID = 0x01,
    XBUS_SET_PERIOD = 0x04,
    XBUS_SET_PERIOD_ACK = 0x05,
    XBUS_GOTO_MEASUREMENT = 0x10,
    XBUS_GOTO_MEASUREMENT_ACK = 0x11,
    XBUS_REQ_FW_REV = 0x12,
    XBUS_FIRMWARE_REV = 0x13,
    XBUS_REQ_PRODUCT_CODE = 0x1C,
    XBUS_PRODUCT_CODE = 0x1D,
    XBUS_GOTO_CONFIG = 0x30,
    XBUS_GOTO_CONFIG_ACK = 0x31,
    XBUS_MT_DATA = 0x32,
    XBUS_MT_DATA2 = 0x36,
    XBUS_WAKE_UP = 0x3E,
    XBUS_ERROR = 0x42,
    XBUS_SET_OUTPUT_CONFIGURATION = 0xC0,
    XBUS_SET_OUTPUT_CONFIGURATION_ACK = 0xC1,
    XBUS_SET_OUTPUT_MODE = 0xD0,
    XBUS_SET_OUTPUT_MODE_ACK = 0xD1,
    XBUS_SET_OUTPUT_SETTINGS = 0xD2,
    XBUS_SET_OUTPUT_SETTINGS_ACK = 0xD3
} xbus_mid_t;

/* One checked frame; payload points into the parser's buffer, valid during the callback. */
typedef struct {
    uint8_t mid;
    uint16_t len;
    const uint8_t *payload;
} xbus_msg_t;

/* Called once per complete, checksum-valid message, in order. */
typedef void (*xbus_msg_fn)(void *ctx, const xbus_msg_t *msg);

typedef struct {
    uint32_t frames;
    uint32_t garbage_bytes;
    uint32_t checksum_errors;
    uint32_t bad_length;
} xbus_counters_t;

typedef struct {
    uint8_t buf[XBUS_BUF_SIZE];
    uint16_t n;           /* bytes held */
    uint16_t max_payload; /* longest payload accepted (a corrupted length must not stall it) */
    xbus_counters_t counters;
} xbus_parser_t;

/* max_payload is clamped to XBUS_MAX_PAYLOAD. */
void xbus_parser_init(xbus_parser_t *p, uint16_t max_payload);
void xbus_parser_set_max_payload(xbus_parser_t *p, uint16_t max_payload);

/* Add received bytes; calls fn for every complete, valid message. A header that claims more
 * bytes than have arrived is not trusted blindly: when a complete valid frame already sits
 * behind it, the header was garbage and is skipped. Returns the messages delivered. */
size_t xbus_feed(xbus_parser_t *p, const uint8_t *data, size_t n, xbus_msg_fn fn, void *ctx);

/* Bytes still missing from the frame in progress, or dflt if none is started. */
size_t xbus_bytes_needed(const xbus_parser_t *p, size_t dflt);

/* One frame to the master BID into out (extended length above 254 payload bytes). Returns
 * its length, or 0 if it does not fit in out_cap. */
size_t xbus_encode(uint8_t mid, const uint8_t *payload, size_t len, uint8_t *out, size_t out_cap);

#endif
