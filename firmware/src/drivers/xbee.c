/* XBee API frames and the telemetry link: see xbee.h. */
#include "drivers/xbee.h"

#include <string.h>

#include "hal.h"

static bool needs_escape(uint8_t b) { return b == 0x7E || b == 0x7D || b == 0x11 || b == 0x13; }

size_t xbee_api_frame(const uint8_t *frame_data, size_t n, bool escaped, uint8_t *out, size_t out_cap)
{
    uint8_t body_head[2] = {(uint8_t)(n >> 8), (uint8_t)n};
    uint8_t sum = 0, cs;
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        sum = (uint8_t)(sum + frame_data[i]);
    cs = (uint8_t)(0xFF - sum);
    if (out_cap < 1)
        return 0;
    out[k++] = XBEE_START;
    for (size_t i = 0; i < n + 3; i++) {
        uint8_t b = i < 2 ? body_head[i] : (i < n + 2 ? frame_data[i - 2] : cs);
        if (escaped && needs_escape(b)) {
            if (k + 2 > out_cap)
                return 0;
            out[k++] = XBEE_ESCAPE;
            out[k++] = (uint8_t)(b ^ XBEE_XOR);
        } else {
            if (k + 1 > out_cap)
                return 0;
            out[k++] = b;
        }
    }
    return k;
}

size_t xbee_tx16(uint8_t frame_id, uint16_t dest16, const uint8_t *payload, size_t len, uint8_t options,
                 uint8_t *out, size_t out_cap)
{
    if (len > XBEE_MAX_RF_PAYLOAD || 5 + len > out_cap)
        return 0;
    out[0] = XBEE_TX16;
    out[1] = frame_id;
    out[2] = (uint8_t)(dest16 >> 8);
    out[3] = (uint8_t)dest16;
    out[4] = options;
    memcpy(out + 5, payload, len);
    return 5 + len;
}

void xbee_parser_init(xbee_parser_t *p, bool escaped)
{
    memset(p, 0, sizeof *p);
    p->escaped = escaped;
}

static void drop_raw(xbee_parser_t *p, size_t k)
{
    memmove(p->raw, p->raw + k, p->n - k);
    p->n -= k;
}

/* Unescape the body after the delimiter at raw[0] into body; *interrupted when a new 7E cut
 * it short; *raw_used the raw bytes that held it. Returns the body length. */
static size_t unescape(const xbee_parser_t *p, uint8_t *body, size_t cap, bool *interrupted)
{
    size_t i = 1, k = 0;
    *interrupted = false;
    while (i < p->n && k < cap) {
        uint8_t b = p->raw[i];
        if (p->escaped && b == XBEE_START) {
            *interrupted = true;
            return k;
        }
        if (p->escaped && b == XBEE_ESCAPE) {
            if (i + 1 >= p->n)
                break; /* the escaped byte has not arrived yet */
            body[k++] = (uint8_t)(p->raw[i + 1] ^ XBEE_XOR);
            i += 2;
        } else {
            body[k++] = b;
            i++;
        }
    }
    return k;
}

/* Raw bytes (delimiter included) that hold the first m bytes of the body. */
static size_t raw_length(const xbee_parser_t *p, size_t m)
{
    size_t i = 1, count = 0;
    if (!p->escaped)
        return 1 + m;
    while (count < m) {
        i += p->raw[i] == XBEE_ESCAPE ? 2 : 1;
        count++;
    }
    return i;
}

void xbee_parser_feed(xbee_parser_t *p, const uint8_t *data, size_t n,
                      void (*fn)(void *ctx, const uint8_t *frame, size_t len), void *ctx)
{
    static uint8_t body[XBEE_MAX_FRAME_DATA + 4];
    size_t used = 0;
    do {
        size_t room = sizeof p->raw - p->n;
        size_t take = n - used < room ? n - used : room;
        memcpy(p->raw + p->n, data + used, take);
        p->n += take;
        used += take;
        while (p->n) {
            size_t start = 0, blen, len;
            bool interrupted;
            while (start < p->n && p->raw[start] != XBEE_START)
                start++;
            if (start == p->n) {
                p->counters.garbage_bytes += (uint32_t)p->n;
                p->n = 0;
                break;
            }
            if (start) {
                p->counters.garbage_bytes += (uint32_t)start;
                drop_raw(p, start);
            }
            blen = unescape(p, body, sizeof body, &interrupted);
            len = blen >= 2 ? ((size_t)body[0] << 8) | body[1] : XBEE_MAX_RF_PAYLOAD;
            if (len > XBEE_MAX_FRAME_DATA) { /* no 802.15.4 frame is this long: a corrupted header */
                p->counters.bad_length++;
                drop_raw(p, 1);
                continue;
            }
            if (blen < len + 3) {
                if (interrupted) { /* a new 7E started before this frame was complete */
                    p->counters.truncated_frames++;
                    drop_raw(p, 1);
                    continue;
                }
                if (p->n == sizeof p->raw) { /* cannot complete in the buffer: give it up */
                    p->counters.garbage_bytes++;
                    drop_raw(p, 1);
                    continue;
                }
                break;
            }
            {
                uint8_t sum = 0;
                for (size_t i = 0; i < len; i++)
                    sum = (uint8_t)(sum + body[2 + i]);
                if ((uint8_t)(sum + body[2 + len]) != 0xFF) {
                    p->counters.checksum_errors++;
                    drop_raw(p, 1);
                    continue;
                }
            }
            p->counters.frames++;
            if (fn)
                fn(ctx, body + 2, len);
            drop_raw(p, raw_length(p, len + 3));
        }
    } while (used < n);
}

void xbee_link_init(xbee_link_t *l, bool escaped, uint16_t dest16, bool request_status, int32_t max_out_waiting)
{
    memset(l, 0, sizeof *l);
    l->escaped = escaped;
    l->dest16 = dest16;
    l->request_status = request_status;
    l->max_out_waiting = max_out_waiting;
    xbee_parser_init(&l->parser, escaped);
}

static void on_frame(void *ctx, const uint8_t *frame, size_t len)
{
    xbee_link_t *l = ctx;
    if (frame[0] == XBEE_TX_STATUS && len >= 3) {
        if (frame[2] == 0)
            l->counters.tx_ok++;
        else
            l->counters.tx_failed++;
    } else {
        l->counters.rx_other++;
    }
}

int xbee_link_drain(xbee_link_t *l)
{
    uint8_t rx[128];
    for (;;) {
        int32_t waiting = hal_uart_in_waiting(HAL_UART_TELEMETRY);
        int32_t got;
        if (waiting <= 0)
            return waiting;
        got = hal_uart_read(HAL_UART_TELEMETRY, rx, (size_t)waiting < sizeof rx ? (size_t)waiting : sizeof rx, 0);
        if (got <= 0)
            return got;
        xbee_parser_feed(&l->parser, rx, (size_t)got, on_frame, l);
    }
}

int xbee_link_send(xbee_link_t *l, const uint8_t *payload, size_t len)
{
    uint8_t data[5 + XBEE_MAX_RF_PAYLOAD], wire[XBEE_MAX_WIRE];
    size_t n, w;
    int32_t waiting, written;
    int r = xbee_link_drain(l);
    if (r < 0)
        return r;
    waiting = hal_uart_out_waiting(HAL_UART_TELEMETRY);
    if (waiting < 0)
        return waiting;
    if (waiting > l->max_out_waiting) {
        l->counters.dropped_busy++;
        return 0;
    }
    if (l->request_status)
        l->frame_id = (uint8_t)(l->frame_id % 255 + 1);
    n = xbee_tx16(l->frame_id, l->dest16, payload, len, 0, data, sizeof data);
    if (!n)
        return 0;
    w = xbee_api_frame(data, n, l->escaped, wire, sizeof wire);
    if (!w)
        return 0;
    written = hal_uart_write(HAL_UART_TELEMETRY, wire, w);
    if (written < 0)
        return written;
    if ((size_t)written < w) {
        l->counters.short_writes++;
        return 0;
    }
    l->counters.sent++;
    return 1;
}
