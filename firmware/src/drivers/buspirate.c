/* Bus Pirate binary SPI bridge: see buspirate.h. */
#include "drivers/buspirate.h"

#include <stdio.h>
#include <string.h>

#include "log.h"

#define CONFIG_MODE0_3V3 (BP_CONFIG | 0x0A)              /* 3.3 V push-pull, SPI mode 0 */
#define PERIPHERALS_POWER_CS_HIGH (BP_PERIPHERALS | 0x08 | 0x01)

int bp_speed_code(uint32_t speed_hz)
{
    static const uint32_t speeds[8] = {30000, 125000, 250000, 1000000, 2000000, 2600000, 4000000, 8000000};
    for (int i = 0; i < 8; i++)
        if (speeds[i] == speed_hz)
            return i;
    return -1;
}

size_t bp_encode_transfers(const uint8_t *mosi, const uint8_t *lengths, size_t n, uint8_t *out, size_t out_cap)
{
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        size_t len = lengths[i];
        if (len < 1 || len > 16 || k + len + 3 > out_cap)
            return 0;
        out[k++] = BP_CS_LOW;
        out[k++] = (uint8_t)(BP_BULK | (len - 1));
        memcpy(out + k, mosi, len);
        mosi += len;
        k += len;
        out[k++] = BP_CS_HIGH;
    }
    return k;
}

size_t bp_reply_length(const uint8_t *lengths, size_t n)
{
    size_t size = 0;
    for (size_t i = 0; i < n; i++)
        size += lengths[i] + 3u;
    return size;
}

bool bp_acks_ok(const uint8_t *reply, size_t len, const uint8_t *lengths, size_t n)
{
    size_t i = 0;
    for (size_t t = 0; t < n; t++) {
        size_t pos[3] = {i, i + 1, i + 2 + lengths[t]};
        for (int k = 0; k < 3; k++) {
            if (pos[k] >= len)
                return true;
            if (reply[pos[k]] != BP_ACK)
                return false;
        }
        i += lengths[t] + 3u;
    }
    return len <= i;
}

int bp_decode_transfers(const uint8_t *reply, size_t len, const uint8_t *lengths, size_t n, uint8_t *miso)
{
    size_t i = 0;
    if (len != bp_reply_length(lengths, n))
        return 1;
    for (size_t t = 0; t < n; t++) {
        size_t m = lengths[t];
        if (reply[i] != BP_ACK || reply[i + 1] != BP_ACK || reply[i + 2 + m] != BP_ACK)
            return 2;
        memcpy(miso, reply + i + 2, m);
        miso += m;
        i += m + 3;
    }
    return 0;
}

/* -- entry ------------------------------------------------------------------------------------ */

static void show_hex(const uint8_t *b, size_t n, char *out, size_t cap)
{
    size_t k = 0;
    out[0] = '\0';
    for (size_t i = 0; i < n && k + 4 < cap; i++)
        k += (size_t)snprintf(out + k, cap - k, i ? " %02x" : "%02x", b[i]);
}

static const char *show_reply(const bp_entry_t *e, int i)
{
    return e->reply_len[i] > 1 ? e->reply[i] : "01";
}

void bp_entry_start(bp_entry_t *e, uint32_t speed_hz, uint64_t quiet_ns, uint64_t reply_timeout_ns, uint64_t now_ns,
                    uint8_t zeros_out[BP_RESET_ZEROS])
{
    int code = bp_speed_code(speed_hz);
    static const char ack[2] = {BP_ACK, 0};
    memset(e, 0, sizeof *e);
    e->cmd[0] = BP_EXIT_TO_BBIO;
    e->reply[0] = "BBIO1";
    e->cmd[1] = BP_ENTER_SPI;
    e->reply[1] = "SPI1";
    e->cmd[2] = CONFIG_MODE0_3V3;
    e->cmd[3] = (uint8_t)(BP_SPEED | (code < 0 ? 0 : code));
    e->cmd[4] = PERIPHERALS_POWER_CS_HIGH;
    e->cmd[5] = BP_CS_HIGH;
    for (int i = 2; i < BP_SCRIPT_STEPS; i++)
        e->reply[i] = ack;
    for (int i = 0; i < BP_SCRIPT_STEPS; i++)
        e->reply_len[i] = (uint8_t)(i < 2 ? strlen(e->reply[i]) : 1);
    e->quiet_ns = quiet_ns;
    e->reply_timeout_ns = reply_timeout_ns;
    e->state = BP_ENTRY_DRAIN;
    e->t_start = e->t_last_rx = now_ns;
    memset(zeros_out, 0, BP_RESET_ZEROS);
}

static int fail(bp_entry_t *e)
{
    e->state = BP_ENTRY_FAILED;
    return -1;
}

static int send_step(bp_entry_t *e, int i, uint64_t now_ns)
{
    e->i = i;
    e->got_n = 0;
    e->t_sent = now_ns;
    return e->cmd[i];
}

int bp_entry_step(bp_entry_t *e, const uint8_t *data, size_t n, uint64_t now_ns, bool *flush)
{
    *flush = false;
    if (e->state == BP_ENTRY_DRAIN) {
        if (n) {
            e->drained += (uint32_t)n;
            e->t_last_rx = now_ns;
        }
        if (now_ns - e->t_last_rx >= e->quiet_ns) {
            e->state = BP_ENTRY_EXCHANGE;
            *flush = true;
            return send_step(e, 0, now_ns);
        }
        if (now_ns - e->t_start >= e->quiet_ns + e->reply_timeout_ns) {
            snprintf(e->reason, sizeof e->reason, "line not quiet %g s after %d zeros (%lu bytes)",
                     (double)e->reply_timeout_ns / 1e9, BP_RESET_ZEROS, (unsigned long)e->drained);
            return fail(e);
        }
        return -1;
    }
    if (e->state != BP_ENTRY_EXCHANGE)
        return -1;
    {
        const uint8_t *expected = (const uint8_t *)e->reply[e->i];
        size_t want = e->reply_len[e->i];
        char got[40];
        for (size_t k = 0; k < n; k++) {
            if (e->got_n < sizeof e->got)
                e->got[e->got_n] = data[k];
            e->got_n++;
        }
        if (e->got_n > want || memcmp(e->got, expected, e->got_n) != 0) { /* a wrong byte, or one too many */
            show_hex(e->got, e->got_n < sizeof e->got ? e->got_n : sizeof e->got, got, sizeof got);
            snprintf(e->reason, sizeof e->reason, "%02x answered %s (expected %s)", e->cmd[e->i], got,
                     show_reply(e, e->i));
            return fail(e);
        }
        if (e->got_n == want) {
            if (e->i + 1 == BP_SCRIPT_STEPS) {
                e->state = BP_ENTRY_DONE;
                return -1;
            }
            return send_step(e, e->i + 1, now_ns);
        }
        if (now_ns - e->t_sent >= e->reply_timeout_ns) {
            show_hex(e->got, e->got_n, got, sizeof got);
            snprintf(e->reason, sizeof e->reason, "no %s after %02x (got %s)", show_reply(e, e->i), e->cmd[e->i],
                     e->got_n ? got : "nothing");
            return fail(e);
        }
    }
    return -1;
}

/* -- the bridge --------------------------------------------------------------------------------- */

void bp_init(bp_bridge_t *b, const bp_port_t *port, uint32_t speed_hz, uint32_t entry_attempts,
             uint64_t read_timeout_ns, uint64_t reply_timeout_ns, uint64_t quiet_ns, uint64_t resync_interval_ns)
{
    memset(b, 0, sizeof *b);
    b->port = *port;
    b->speed_hz = speed_hz;
    b->entry_attempts = entry_attempts;
    b->read_timeout_ns = read_timeout_ns;
    b->reply_timeout_ns = reply_timeout_ns;
    b->quiet_ns = quiet_ns;
    b->resync_interval_ns = resync_interval_ns;
    b->state = BP_WAITING; /* until bp_enter_spi (or the first exchange) enters */
}

static void begin_entry(bp_bridge_t *b)
{
    uint8_t zeros[BP_RESET_ZEROS];
    b->port.flush_input(b->port.ctx);
    bp_entry_start(&b->entry, b->speed_hz, b->quiet_ns, b->reply_timeout_ns, b->port.now_ns(), zeros);
    b->port.write(b->port.ctx, zeros, sizeof zeros);
    b->state = BP_ENTERING;
}

static void entry_step(bp_bridge_t *b, const uint8_t *data, size_t n)
{
    bool flush;
    int out = bp_entry_step(&b->entry, data, n, b->port.now_ns(), &flush);
    if (flush)
        b->port.flush_input(b->port.ctx);
    if (out >= 0) {
        uint8_t byte = (uint8_t)out;
        b->port.write(b->port.ctx, &byte, 1);
    }
}

bool bp_enter_spi(bp_bridge_t *b, char *why, size_t why_len)
{
    const char *reason = "not tried";
    uint8_t rx[64];
    for (uint32_t attempt = 1; attempt <= b->entry_attempts; attempt++) {
        begin_entry(b);
        while (b->entry.state == BP_ENTRY_DRAIN || b->entry.state == BP_ENTRY_EXCHANGE) {
            int32_t waiting = b->port.in_waiting(b->port.ctx);
            size_t want = waiting > 0 ? ((size_t)waiting < sizeof rx ? (size_t)waiting : sizeof rx) : 1u;
            int32_t got = b->port.read(b->port.ctx, rx, want, b->read_timeout_ns); /* in silence waits */
            entry_step(b, rx, got > 0 ? (size_t)got : 0u);
        }
        if (b->entry.state == BP_ENTRY_DONE) {
            b->state = BP_READY;
            if (log_begin(LOG_INFO, "adc.spi_mode")) {
                log_int("attempts", attempt);
                log_int("speed_hz", b->speed_hz);
                log_int("drained", b->entry.drained);
                log_end();
            }
            return true;
        }
        reason = b->entry.reason;
        if (log_begin(LOG_WARNING, "adc.entry_retry")) {
            log_int("attempt", attempt);
            log_str("reason", reason);
            log_end();
        }
    }
    snprintf(why, why_len, "Bus Pirate did not enter binary SPI mode after %lu attempt(s): %s",
             (unsigned long)b->entry_attempts, reason);
    return false;
}

void bp_lose_sync(bp_bridge_t *b, bool reply_in_flight)
{
    b->counters.sync_lost++;
    b->state = BP_WAITING;
    b->retry_set = false;
    if (reply_in_flight)
        b->stale_until = b->port.now_ns() + b->reply_timeout_ns;
}

/* One non-blocking step of the in-flight re-entry; true once the bridge is ready. */
static bool poll_entry(bp_bridge_t *b, uint64_t t_ns)
{
    uint8_t rx[64];
    int32_t waiting;
    if (b->state == BP_WAITING) {
        if (b->retry_set && t_ns < b->retry_t_ns)
            return false;
        if (b->port.now_ns() < b->stale_until) {
            b->counters.samples_waiting_stale++;
            return false;
        }
        b->counters.resyncs++;
        begin_entry(b);
        return false; /* replies come later: the next samples poll them */
    }
    waiting = b->port.in_waiting(b->port.ctx);
    if (waiting > 0) {
        int32_t got = b->port.read(b->port.ctx, rx, (size_t)waiting < sizeof rx ? (size_t)waiting : sizeof rx, 0);
        entry_step(b, rx, got > 0 ? (size_t)got : 0u);
    } else {
        entry_step(b, rx, 0);
    }
    if (b->entry.state == BP_ENTRY_DONE) {
        b->state = BP_READY;
        if (log_begin(LOG_INFO, "adc.resynced")) {
            log_int("resyncs", b->counters.resyncs);
            log_int("drained", b->entry.drained);
            log_end();
        }
        return true;
    }
    if (b->entry.state == BP_ENTRY_FAILED) {
        uint32_t n_fail = ++b->counters.resync_failures;
        if ((n_fail & (n_fail - 1)) == 0 && log_begin(LOG_WARNING, "adc.resync_failed")) {
            log_int("failures", n_fail);
            log_str("reason", b->entry.reason);
            log_end();
        }
        b->state = BP_WAITING;
        b->retry_set = true;
        b->retry_t_ns = t_ns + b->resync_interval_ns;
    }
    return false;
}

/* The owed bytes of a late reply; true once the line is clear. */
static bool collect_late(bp_bridge_t *b)
{
    int32_t waiting = b->port.in_waiting(b->port.ctx);
    if (waiting > 0) {
        size_t want = (size_t)waiting < b->owed ? (size_t)waiting : b->owed;
        int32_t got = b->port.read(b->port.ctx, b->partial + b->partial_n, want, 0);
        if (got > 0) {
            b->partial_n += (size_t)got;
            b->owed -= (size_t)got;
        }
    }
    if (b->owed) {
        if (b->port.now_ns() - b->pending_since >= b->reply_timeout_ns) {
            b->counters.replies_lost++;
            bp_lose_sync(b, false);
        }
        return false;
    }
    {
        uint8_t miso[BP_MAX_WIRE];
        if (bp_decode_transfers(b->partial, b->partial_n, b->lengths, b->n_transfers, miso) == 2) {
            b->counters.bad_ack++;
            bp_lose_sync(b, true);
            return false;
        }
    }
    b->counters.late_replies_discarded++;
    b->state = BP_READY;
    return true;
}

/* Read until n bytes or timeout_ns after the call; returns the count or < 0. */
static int32_t read_exact(bp_bridge_t *b, uint8_t *buf, size_t n, uint64_t timeout_ns)
{
    uint64_t deadline = b->port.now_ns() + timeout_ns;
    size_t have = 0;
    while (have < n) {
        uint64_t now = b->port.now_ns();
        int32_t got;
        if (now >= deadline && have)
            break;
        got = b->port.read(b->port.ctx, buf + have, n - have, now < deadline ? deadline - now : 0);
        if (got < 0)
            return got;
        if (got == 0)
            break;
        have += (size_t)got;
    }
    return (int32_t)have;
}

int bp_exchange(bp_bridge_t *b, const uint8_t *mosi, const uint8_t *lengths, size_t n, uint8_t *miso, uint64_t t_ns)
{
    bp_link_state_t state = b->state;
    uint8_t wire[BP_MAX_WIRE], reply[BP_MAX_WIRE];
    size_t wire_n, size;
    int32_t written, got;
    if (n > BP_MAX_TRANSFERS)
        return -1;
    if (state == BP_REPLY_PENDING && !collect_late(b))
        return 1;
    if ((state == BP_ENTERING || state == BP_WAITING) && !poll_entry(b, t_ns))
        return 1;
    if (b->port.in_waiting(b->port.ctx) > 0) { /* nothing is owed: junk must never shift a reply */
        b->counters.unexpected_input++;
        b->port.flush_input(b->port.ctx);
    }
    wire_n = bp_encode_transfers(mosi, lengths, n, wire, sizeof wire);
    written = b->port.write(b->port.ctx, wire, wire_n);
    b->counters.requests++;
    if (written < 0)
        return written;
    if ((size_t)written < wire_n) { /* the port does not block: the bridge holds a torn request */
        b->counters.short_writes++;
        bp_lose_sync(b, true);
        return 2;
    }
    size = bp_reply_length(lengths, n);
    got = read_exact(b, reply, size, b->read_timeout_ns);
    if (got < 0)
        return got;
    if ((size_t)got == size) {
        int r = bp_decode_transfers(reply, size, lengths, n, miso);
        if (r == 0) {
            b->counters.transfers++;
            return 0;
        }
        if (r == 1)
            b->counters.short_replies++;
        else
            b->counters.bad_ack++;
        bp_lose_sync(b, true);
        return 2;
    }
    if (!bp_acks_ok(reply, (size_t)got, lengths, n)) {
        b->counters.bad_ack++;
        bp_lose_sync(b, true);
        return 2;
    }
    /* late, not lost: the rest is owed and collected before the next write */
    b->counters.late_replies++;
    b->state = BP_REPLY_PENDING;
    memcpy(b->partial, reply, (size_t)got);
    b->partial_n = (size_t)got;
    b->owed = size - (size_t)got;
    memcpy(b->lengths, lengths, n);
    b->n_transfers = n;
    b->pending_since = b->port.now_ns();
    return 2;
}
