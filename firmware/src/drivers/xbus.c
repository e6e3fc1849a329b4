/* Xbus framing: see xbus.h. */
#include "drivers/xbus.h"

#include <string.h>

void xbus_parser_init(xbus_parser_t *p, uint16_t max_payload)
{
    memset(p, 0, sizeof *p);
    xbus_parser_set_max_payload(p, max_payload);
}

void xbus_parser_set_max_payload(xbus_parser_t *p, uint16_t max_payload)
{
    p->max_payload = max_payload > XBUS_MAX_PAYLOAD ? (uint16_t)XBUS_MAX_PAYLOAD : max_payload;
}

size_t xbus_bytes_needed(const xbus_parser_t *p, size_t dflt)
{
    size_t held = p->n;
    size_t total;
    if (held < 4)
        return held ? dflt - held : dflt;
    if (p->buf[3] == XBUS_EXTENDED_LEN) {
        if (held < 6)
            return 6 - held;
        total = 7u + (((size_t)p->buf[4] << 8) | p->buf[5]);
    } else {
        total = 5u + p->buf[3];
    }
    return total > held ? total - held : 1u;
}

/* Offset of the first FA FF at or after from, or -1. */
static int find_preamble(const xbus_parser_t *p, size_t from)
{
    for (size_t i = from; i + 1 < p->n; i++)
        if (p->buf[i] == XBUS_PREAMBLE && p->buf[i + 1] == XBUS_BID_MASTER)
            return (int)i;
    return -1;
}

/* The frame at buf[i]: > 0 its total length (header length in *head), 0 more bytes are
 * needed, -1 a length beyond max_payload, -2 a checksum that fails. */
static int frame_at(const xbus_parser_t *p, size_t i, size_t *head)
{
    size_t avail = p->n - i;
    size_t len, h = 4, total;
    uint8_t sum = 0;
    if (avail < 4)
        return 0;
    len = p->buf[i + 3];
    if (len == XBUS_EXTENDED_LEN) {
        if (avail < 6)
            return 0;
        len = ((size_t)p->buf[i + 4] << 8) | p->buf[i + 5];
        h = 6;
    }
    if (len > p->max_payload)
        return -1;
    total = h + len + 1;
    if (avail < total)
        return 0;
    for (size_t k = i + 1; k < i + total; k++)
        sum = (uint8_t)(sum + p->buf[k]);
    if (sum)
        return -2;
    *head = h;
    return (int)total;
}

static void drop(xbus_parser_t *p, size_t k)
{
    memmove(p->buf, p->buf + k, p->n - k);
    p->n = (uint16_t)(p->n - k);
}

/* Offset of the first complete, valid frame after position 0, or -1. */
static int later_frame(const xbus_parser_t *p)
{
    size_t head;
    int j = find_preamble(p, 1);
    while (j > 0) {
        if (frame_at(p, (size_t)j, &head) > 0)
            return j;
        j = find_preamble(p, (size_t)j + 1);
    }
    return -1;
}

/* Take every frame out of what the buffer holds. */
static size_t parse(xbus_parser_t *p, xbus_msg_fn fn, void *ctx)
{
    size_t delivered = 0, start = 0, head = 0;
    for (;;) {
        int at = find_preamble(p, start);
        int total;
        if (at < 0) {
            /* keep a trailing 0xFA: it may be the first half of the next preamble */
            size_t keep = (p->n && p->buf[p->n - 1] == XBUS_PREAMBLE) ? 1u : 0u;
            p->counters.garbage_bytes += (uint32_t)(p->n - keep);
            drop(p, p->n - keep);
            break;
        }
        if (at) {
            p->counters.garbage_bytes += (uint32_t)at;
            drop(p, (size_t)at);
            start = 0;
        }
        total = frame_at(p, 0, &head);
        if (total == 0) {
            int later = later_frame(p);
            if (later < 0)
                break;
            p->counters.garbage_bytes += (uint32_t)later;
            drop(p, (size_t)later);
            continue;
        }
        if (total < 0) {
            if (total == -1)
                p->counters.bad_length++;
            else
                p->counters.checksum_errors++;
            start = 1;
            continue;
        }
        {
            xbus_msg_t msg;
            msg.mid = p->buf[2];
            msg.len = (uint16_t)((size_t)total - head - 1);
            msg.payload = p->buf + head;
            p->counters.frames++;
            if (fn)
                fn(ctx, &msg);
            delivered++;
        }
        drop(p, (size_t)total);
    }
    return delivered;
}

size_t xbus_feed(xbus_parser_t *p, const uint8_t *data, size_t n, xbus_msg_fn fn, void *ctx)
{
    size_t delivered = 0;
    do {
        size_t room = XBUS_BUF_SIZE - p->n;
        size_t take = n < room ? n : room;
        memcpy(p->buf + p->n, data, take);
        p->n = (uint16_t)(p->n + take);
        data += take;
        n -= take;
        delivered += parse(p, fn, ctx);
        if (p->n == XBUS_BUF_SIZE) {
            /* cannot happen with max_payload <= XBUS_MAX_PAYLOAD (a full buffer holds a whole
             * frame or garbage), but never wedge: drop the oldest byte */
            p->counters.garbage_bytes++;
            drop(p, 1);
        }
    } while (n);
    return delivered;
}

size_t xbus_encode(uint8_t mid, const uint8_t *payload, size_t len, uint8_t *out, size_t out_cap)
{
    size_t head = len < XBUS_EXTENDED_LEN ? 4u : 6u;
    size_t total = head + len + 1;
    uint8_t sum = 0;
    if (len > 0xFFFFu || total > out_cap)
        return 0;
    out[0] = XBUS_PREAMBLE;
    out[1] = XBUS_BID_MASTER;
    out[2] = mid;
    if (head == 4) {
        out[3] = (uint8_t)len;
    } else {
        out[3] = XBUS_EXTENDED_LEN;
        out[4] = (uint8_t)(len >> 8);
        out[5] = (uint8_t)len;
    }
    if (len)
        memcpy(out + head, payload, len);
    for (size_t k = 1; k < total - 1; k++)
        sum = (uint8_t)(sum + out[k]);
    out[total - 1] = (uint8_t)(0u - sum);
    return total;
}
