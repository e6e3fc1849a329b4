/*
 * Bus Pirate v3 binary-mode SPI (BBIO1 / SPI1) as the flight code's SPI bridge on a host:
 * the protocol, the entry sequence (a sans-I/O state machine) and the bridge that runs one
 * sample's transfers, collects late replies and re-enters in flight. As
 * flightcode/drivers/buspirate_protocol.py and buspirate_spi.py (docs/flightcode.md, loop
 * step 2). Used by the posix hardware layer; it reaches its serial line through a byte port.
 *
 * Protocol: 20 x 00 -> BBIO1 (each further 00 answers BBIO1 again); 01 -> SPI1; in SPI mode
 * 02/03 CS low/high, 1n + n+1 bytes bulk transfer, 4x peripherals, 6x speed, 8x config each
 * answer 01. A sample's conversions go out as one write (02 1n data 03 per transfer) and
 * come back as one reply of fixed length (01 01 miso.. 01 per transfer).
 */
#ifndef FW_BUSPIRATE_H
#define FW_BUSPIRATE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define BP_ACK 0x01u
#define BP_RESET_ZEROS 20
#define BP_MAX_TRANSFERS 4
#define BP_MAX_WIRE (BP_MAX_TRANSFERS * 19)

typedef enum {
    BP_EXIT_TO_BBIO = 0x00,
    BP_ENTER_SPI = 0x01,
    BP_CS_LOW = 0x02,
    BP_CS_HIGH = 0x03,
    BP_BULK = 0x10,        /* | (n - 1), n = 1..16 */
    BP_PERIPHERALS = 0x40, /* | power<<3 | pullups<<2 | aux<<1 | cs */
    BP_SPEED = 0x60,       /* | speed code */
    BP_CONFIG = 0x80       /* | hiz_off<<3 | ckp<<2 | cke<<1 | smp */
} bp_cmd_t;

/* SPI clock (Hz) -> speed code of the 6x command; -1 if the Bus Pirate has no such speed. */
int bp_speed_code(uint32_t speed_hz);

/* One pipelined write for transfers of the given lengths (MOSI bytes back to back): its
 * length, or 0 if a length is outside 1..16 or it does not fit out_cap. */
size_t bp_encode_transfers(const uint8_t *mosi, const uint8_t *lengths, size_t n, uint8_t *out, size_t out_cap);
/* Bytes the Bus Pirate answers to that write. */
size_t bp_reply_length(const uint8_t *lengths, size_t n);
/* True if every ack position a (possibly partial) reply reaches holds 01. */
bool bp_acks_ok(const uint8_t *reply, size_t len, const uint8_t *lengths, size_t n);
/* Split a whole reply into MISO bytes (back to back in miso): 0 ok, 1 short, 2 bad ack. */
int bp_decode_transfers(const uint8_t *reply, size_t len, const uint8_t *lengths, size_t n, uint8_t *miso);

/* -- entry: sans-I/O ------------------------------------------------------------------------- */

typedef enum { BP_ENTRY_DRAIN, BP_ENTRY_EXCHANGE, BP_ENTRY_DONE, BP_ENTRY_FAILED } bp_entry_state_t;

#define BP_SCRIPT_STEPS 6
typedef struct {
    uint8_t cmd[BP_SCRIPT_STEPS];
    const char *reply[BP_SCRIPT_STEPS]; /* exact reply: "BBIO1", "SPI1" or "\x01" */
    uint8_t reply_len[BP_SCRIPT_STEPS];
    uint64_t quiet_ns, reply_timeout_ns;
    bp_entry_state_t state;
    char reason[120];
    uint32_t drained; /* bytes discarded while draining */
    int i;
    uint8_t got[8];
    size_t got_n;
    uint64_t t_start, t_last_rx, t_sent;
} bp_entry_t;

/* A fresh attempt: writes the 20 zeros into zeros_out (the caller flushes input first). */
void bp_entry_start(bp_entry_t *e, uint32_t speed_hz, uint64_t quiet_ns, uint64_t reply_timeout_ns, uint64_t now_ns,
                    uint8_t zeros_out[BP_RESET_ZEROS]);
/* Feed what was read since the last call: returns the byte to write (or -1 for none) and
 * sets *flush when the input must be flushed first. */
int bp_entry_step(bp_entry_t *e, const uint8_t *data, size_t n, uint64_t now_ns, bool *flush);

/* -- the bridge on a byte port ---------------------------------------------------------------- */

/* The serial line under the bridge (hal_uart semantics: read waits at most timeout_ns for the
 * first byte and returns what has arrived; write never blocks and returns the count taken). */
typedef struct {
    void *ctx;
    int32_t (*read)(void *ctx, uint8_t *buf, size_t max, uint64_t timeout_ns);
    int32_t (*write)(void *ctx, const uint8_t *data, size_t n);
    int32_t (*in_waiting)(void *ctx);
    void (*flush_input)(void *ctx);
    uint64_t (*now_ns)(void);
} bp_port_t;

typedef enum { BP_READY, BP_REPLY_PENDING, BP_ENTERING, BP_WAITING } bp_link_state_t;

typedef struct {
    uint32_t requests, transfers, short_replies, bad_ack, late_replies, late_replies_discarded, replies_lost;
    uint32_t unexpected_input, short_writes, resyncs, resync_failures, samples_waiting_stale;
    uint32_t sync_lost; /* all reasons */
} bp_counters_t;

typedef struct {
    bp_port_t port;
    uint32_t speed_hz;
    uint32_t entry_attempts;
    uint64_t read_timeout_ns, reply_timeout_ns, quiet_ns, resync_interval_ns;
    bp_counters_t counters;
    bp_link_state_t state;
    bp_entry_t entry;
    bool retry_set;
    uint64_t retry_t_ns;   /* WAITING: sensor time of the next attempt */
    uint8_t partial[BP_MAX_WIRE];
    size_t partial_n, owed, reply_size;
    uint8_t lengths[BP_MAX_TRANSFERS];
    size_t n_transfers;
    uint64_t pending_since;
    uint64_t stale_until;  /* no re-entry before this: a garbled reply's rest may still come */
} bp_bridge_t;

void bp_init(bp_bridge_t *b, const bp_port_t *port, uint32_t speed_hz, uint32_t entry_attempts,
             uint64_t read_timeout_ns, uint64_t reply_timeout_ns, uint64_t quiet_ns, uint64_t resync_interval_ns);

/* Boot: entry with retries, blocking; false with the reason in why. */
bool bp_enter_spi(bp_bridge_t *b, char *why, size_t why_len);

/* The data are wrong: re-enter (over the next samples). reply_in_flight: part of a transfer
 * reply may still be on its way, so the re-entry waits reply_timeout first. */
void bp_lose_sync(bp_bridge_t *b, bool reply_in_flight);

/* One sample's transfers (mosi back to back, lengths[i] each): 0 done (miso filled), 1 no
 * request went out (busy), 2 a request went out without a good reply this sample, < 0 a
 * port error. t_ns is sensor time (paces the re-entries). */
int bp_exchange(bp_bridge_t *b, const uint8_t *mosi, const uint8_t *lengths, size_t n, uint8_t *miso, uint64_t t_ns);

#endif
